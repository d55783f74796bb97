import numpy as np, time
from pkmstiff.machine import load_machine
from pkmstiff.calibration import error_model, circle_plan, identifiability, hemisphere_plan
from pkmstiff.calibration.identification import identify
from pkmstiff.calibration.instruments import Setup, instrument
from pkmstiff.calibration.nc_program import NCOptions, program_runs
from pkmstiff.calibration.raw_import import simulate_raw, import_raw
from pkmstiff.calibration.compensation import measurement_plan
from pkmstiff.calibration.plans import Plan
m = load_machine("felix")
st = Setup(instrument("ballbar"), fixed_ball=np.zeros(3), bar_length=0.15)
plan = hemisphere_plan(st, n=90, turns=2).concat(circle_plan(st, "XZ", n=36))
opts = NCOptions(feed=2000/60e3, ramp=4e-3)
runs = program_runs(plan, opts)
params = error_model(m, setup=plan.setup, setup_blocks=("backlash",))
t=time.time()
ide0 = identifiability(m, params, plan); print("rank", ide0.rank, time.time()-t)
rng = np.random.default_rng(3)
delta = np.zeros(params.n); base0 = params.indices(ide0.base_parameters)
delta[base0] = rng.uniform(-1,1,len(base0))*50e-6
bl = params.mask("backlash"); delta[bl] = rng.uniform(20e-6, 60e-6, bl.sum())
for rate, sig in [(50, 0.0), (50, 0.25e-6)]:
    t=time.time(); raws = simulate_raw(m, params, delta, plan, runs, sample_rate=rate, sigma=sig, seed=4); print("sim", time.time()-t, sum(len(r.t) for r in raws))
    t=time.time(); meas, syncs = import_raw(m, plan, runs, raws); print("import", time.time()-t, [f"{s.residual*1e6:.3g}" for s in syncs])
    mp, y = measurement_plan(meas, "felix", "x")
    t=time.time(); ide = identifiability(m, params, mp); res = identify(m, params, mp, y, ident=ide); print("ident", time.time()-t, ide.rank, res.condition_number)
    from pkmstiff.calibration.uncertainty import uncertainty
    unc = uncertainty(res)
    err = res.delta - delta
    print("max err", np.abs(err).max(), "max |err|/sigma", np.max(np.abs(err[res.base])/unc.sigma) if sig else "")
    print("bl", delta[bl]*1e6, res.delta[bl]*1e6)
