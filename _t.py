import time, pkmstiff
t=time.perf_counter()
res = pkmstiff.optimise("hexaglide_joint_orientation", out="/tmp/opt1", budget=24, force=True)
print(time.perf_counter()-t, res.meta["references"], res.meta["outputs"])
