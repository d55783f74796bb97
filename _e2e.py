import numpy as np, time
from pkmstiff.machine import load_machine
from pkmstiff.calibration import error_model, circle_plan, identifiability
from pkmstiff.calibration.identification import identify
from pkmstiff.calibration.instruments import Setup, instrument
from pkmstiff.calibration.nc_program import NCOptions, program_runs, program_text, parse_program
from pkmstiff.calibration.raw_import import simulate_raw, import_raw
from pkmstiff.calibration.compensation import measurement_plan
m = load_machine("felix")
st = Setup(instrument("ballbar"), fixed_ball=np.array([0,0,0.0]), bar_length=0.15)
plan = circle_plan(st, "XY", n=36)
from pkmstiff.calibration.plans import Plan
p2 = circle_plan(Setup(instrument("ballbar"), fixed_ball=np.array([0,0,0.0]), bar_length=0.15), "XZ", n=36)
plan = plan.concat(p2)
print(plan.segments)
opts = NCOptions(feed=2000/60e3, ramp=4e-3)
t=time.time(); runs = program_runs(plan, opts); print("runs", len(runs), [len(r.tcp) for r in runs], time.time()-t)
params = error_model(m, setup=plan.setup, setup_blocks=("backlash",))
rng = np.random.default_rng(3)
delta = np.zeros(params.n); delta[params.chain>=0] = rng.uniform(-1,1,(params.chain>=0).sum())*50e-6
ide0 = identifiability(m, params, plan.concat(plan) if False else plan)
base0 = params.indices(ide0.base_parameters); keep=np.zeros(params.n,bool); keep[base0]=True; delta[~keep]=0
print("base", len(base0))
bl = params.mask("backlash"); delta[bl] = rng.uniform(20e-6, 60e-6, bl.sum())
t=time.time(); raws = simulate_raw(m, params, delta, plan, runs, sample_rate=100, seed=4); print("sim", time.time()-t, [len(r.t) for r in raws])
import os
if os.environ.get("GIVEN"):
    dd = np.random.default_rng(4).uniform(0.2,1.2,4)
    for r_, d_ in zip(raws, dd): r_.start_offset = d_
t=time.time(); meas, syncs = import_raw(m, plan, runs, raws); print("import", time.time()-t)
for s in syncs: print(s.to_dict())
mp, y = measurement_plan(meas, "felix", "x")
print("runs", mp.runs, mp.n_poses)
ide = identifiability(m, params, mp)
print("rank", ide.rank, params.n)
res = identify(m, params, mp, y, ident=ide)
b = res.base
# compare: recovered readings etc.
print("cond", res.condition_number); print("resid rms", np.sqrt(np.mean(res.residual_after**2)), "max err", np.abs(res.delta-delta).max())
for nm in params.names:
    if "backlash" in nm:
        k = params.index(nm); print(nm, delta[k]*1e6, res.delta[k]*1e6)
k=np.argmax(np.abs(res.delta-delta)); print(params.names[k], delta[k], res.delta[k], params.names[k] in ide.base_parameters, params.names[k] in ide0.base_parameters)
print(set(ide.base_parameters)^set(ide0.base_parameters))
