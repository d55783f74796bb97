import numpy as np
from pkmstiff.machine import load_machine
from pkmstiff.calibration import read_plan
from pkmstiff.calibration.nc_program import parse_program
from pkmstiff.calibration.raw_series import read_raw
from pkmstiff.calibration import raw_import as ri
m = load_machine("felix"); plan = read_plan("pkmstiff/calibration/examples/felix_plan.toml")
runs = parse_program(open("/tmp/bbs/felix.nc").read())
d = np.random.default_rng(1).uniform(0.2,1.2,4); print(d)
s = read_raw("/tmp/bbs/raw/run1.txt"); run = runs[0]; fb = plan.setup.fixed_ball; L = plan.setup.bar_length
t1,t2,t3,t4 = ri.kink_times(run, fb, L); Tr=t2-t1; print(t1,t2,t3,t4)
for dt in np.linspace(-0.15,0.15,13):
    print(round(dt,3), ri._fit(s.t, s.deviation, run, fb, L, d[0]+dt, (t3,t4), (t3-Tr/2,t4+Tr/2), m, plan.setup.target), ri._fit(s.t, s.deviation, run, fb, L, d[0]+dt, (t1,t2), (t1-Tr/2,t2+Tr/2), m, plan.setup.target))
y=s.deviation; print(y[0], y[-1], ri._crossing(s.t, y, y[-1]+0.25e-3, False), ri._ramp_mid(run, fb, L, t3, t4, -0.25e-3))
