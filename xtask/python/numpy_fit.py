"""numpy reference for `cargo xtask bench`: the same trace-constrained
full-ellipsoid linear least squares as calib-core's batch fit, timed on the
same number of samples. Prints one JSON line."""
import json
import sys
import time

import numpy as np

n = int(sys.argv[1])
rng = np.random.default_rng(1)
u = rng.normal(size=(n, 3))
u /= np.linalg.norm(u, axis=1, keepdims=True)
d = np.array([[1.05, 0.03, -0.01], [0.03, 0.96, 0.02], [-0.01, 0.02, 1.08]])
raw = 50_000.0 * u @ d.T + np.array([1200.0, -800.0, 350.0]) + 0.4 * rng.normal(size=(n, 3))

t0 = time.perf_counter()
c = raw.mean(axis=0)
s = np.sqrt(((raw - c) ** 2).sum(axis=1).mean())
x, y, z = ((raw - c) / s).T
phi = np.column_stack([x * x + y * y - 2 * z * z, x * x - 2 * y * y + z * z, 2 * x * y, 2 * x * z, 2 * y * z, 2 * x, 2 * y, 2 * z, np.ones(n)])
target = x * x + y * y + z * z
sol = np.linalg.solve(phi.T @ phi, phi.T @ target)  # normal equations, as calib-core's batch
elapsed = time.perf_counter() - t0
print(json.dumps({"numpy_full_fit_s": elapsed, "samples": n, "numpy_version": np.__version__, "u9": float(sol[8])}))
