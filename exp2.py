import numpy as np, time
from pkmstiff.machine import load_machine
from pkmstiff.calibration import read_plan, simulate_readings, identification_jacobian
from pkmstiff.calibration.parameters import parse_errors
from pkmstiff.calibration.setups import PlanSet, moved_plan, setups_error_model
from pkmstiff.calibration.identification import identify, jacobian_at
from pkmstiff.io import read_toml
from pkmstiff.calibration.examples import resolve
m = load_machine("felix")
p = read_plan("example:felix_plan.toml")
balls=[(0,0,0),(0.1,0,-0.1),(0,0.1,-0.1)]
for placed in (False, True):
    ps = PlanSet("x", tuple(moved_plan(p, np.array(b), placed) for b in balls))
    prm = setups_error_model(m, ps, setup_blocks=("bar_offset","ball_offset"))
    print(prm.names[-8:])
    J = identification_jacobian(m, prm, ps).J
    rng=np.random.default_rng(0); d = rng.uniform(-1,1,prm.n)*1e-4
    h=1e-7
    y0 = simulate_readings(m, prm, d, ps).ravel()
    Jd = jacobian_at(m, prm, ps, d)
    fd = np.stack([(simulate_readings(m, prm, d+h*e, ps).ravel()-simulate_readings(m, prm, d-h*e, ps).ravel())/(2*h) for e in np.eye(prm.n)[::7]],1)
    print("FD rel err at d", np.abs(fd-Jd[:, ::7]).max()/np.abs(Jd).max())
    # identification noise-free
    true = parse_errors(read_toml(resolve("example:felix_errors.toml"),"e")["errors"], prm)
    true[prm.chain<0] = rng.uniform(-1,1,(prm.chain<0).sum())*2e-5
    y = simulate_readings(m, prm, true, ps)
    t=time.time(); res = identify(m, prm, ps, y); print("ident", res.rank, np.abs(res.residual_after).max(), time.time()-t)
