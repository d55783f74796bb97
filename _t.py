import time, sys, pkmstiff
for name in sys.argv[1:]:
    t=time.perf_counter()
    res = pkmstiff.optimise(name, out=f"/tmp/opt_{name}", force=True)
    print(name, round(time.perf_counter()-t,1), len(res.front), [(c.values, c.outputs) for c in res.front][:6])
    print(res.meta["references"])
