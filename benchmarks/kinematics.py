"""Throughput of PSM forward kinematics + spatial Jacobian, and the conditioning of J at cp.

    python benchmarks/kinematics.py [--n 100000] [--repeats 5] [--json PATH]

Runs on one core (BLAS/OpenMP threads set to 1 before numpy loads). Prints and writes (JSON):
configurations per second for FK + WORLD Jacobian at cp (best of ``--repeats``), for FK alone, for
wrench_from_torques, and for a per-sample Pinocchio loop for comparison; then the smallest singular
value of the Jacobian that wrench_from_torques inverts (WORLD, and LOCAL_WORLD_ALIGNED at cp) by
insertion band, which is what the damping threshold of psmforce.robot.wrench is judged against.
Target: >= 200,000 configurations/s.
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pinocchio as pin  # noqa: E402

from psmforce.robot import PSM  # noqa: E402
from psmforce.robot.wrench import DEFAULT_SIGMA_THRESHOLD  # noqa: E402
from psmforce.experiments.report import write_json  # noqa: E402

TARGET_CONFIGS_PER_S = 200_000


def _best_time(fn, repeats):
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def _pinocchio_loop(psm, q):
    """The same results (cp pose and WORLD Jacobian, stored) from Pinocchio calls per sample."""
    model, data = psm.model, psm.model.createData()
    fid = model.getFrameId("cp")
    full = np.zeros((q.shape[0], model.nq))
    full[:, :6] = q
    T = np.empty((q.shape[0], 4, 4))
    J = np.empty((q.shape[0], 6, 6))
    for k, qk in enumerate(full):
        pin.computeJointJacobians(model, data, qk)
        pin.updateFramePlacement(model, data, fid)
        T[k] = data.oMf[fid].homogeneous
        J[k] = pin.getFrameJacobian(model, data, fid, pin.WORLD)[:, :6]
    return T, J


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=100_000, help="configurations (default 100000)")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", type=Path, help="write the figures to this JSON file")
    args = parser.parse_args(argv)
    if args.n < 1 or args.repeats < 1:
        parser.error("--n and --repeats must be >= 1")

    psm = PSM()
    rng = np.random.default_rng(args.seed)
    q = rng.uniform(psm.lower_limits[:6], psm.upper_limits[:6], size=(args.n, 6))
    tau = rng.normal(size=(args.n, 6))
    n_loop = min(args.n, 20_000)

    t_fk_jac = _best_time(lambda: psm.forward_kinematics_and_jacobian(q, "cp"), args.repeats)
    t_fk = _best_time(lambda: psm.forward_kinematics(q, "cp"), args.repeats)
    t_wrench = _best_time(lambda: psm.wrench_from_torques(q, tau), args.repeats)
    t_loop = _best_time(lambda: _pinocchio_loop(psm, q[:n_loop]), 1)

    bands = {}
    for convention, expressed_in in (("base", "base"), ("base_at_frame (cp)", "base_at_frame")):
        sigma_min = np.linalg.svd(psm.jacobian(q, "cp", expressed_in), compute_uv=False)[:, -1]
        bands[convention] = []
        for lo, hi in ((0.0, 0.02), (0.02, 0.05), (0.05, 0.10), (0.10, 0.24)):
            sel = (q[:, 2] >= lo) & (q[:, 2] < hi)
            if sel.any():
                bands[convention].append({
                    "insertion_m": [lo, hi], "n": int(sel.sum()),
                    "sigma_min_p0": float(sigma_min[sel].min()),
                    "sigma_min_p1": float(np.percentile(sigma_min[sel], 1)),
                    "sigma_min_p50": float(np.median(sigma_min[sel])),
                    "fraction_damped": float(np.mean(sigma_min[sel] < DEFAULT_SIGMA_THRESHOLD)),
                })

    result = {
        "n_configurations": args.n,
        "threads": 1,
        "fk_plus_spatial_jacobian_configs_per_s": args.n / t_fk_jac,
        "fk_only_configs_per_s": args.n / t_fk,
        "wrench_from_torques_configs_per_s": args.n / t_wrench,
        "pinocchio_per_sample_loop_configs_per_s": n_loop / t_loop,
        "target_configs_per_s": TARGET_CONFIGS_PER_S,
        "meets_target": bool(args.n / t_fk_jac >= TARGET_CONFIGS_PER_S),
        "sigma_threshold": DEFAULT_SIGMA_THRESHOLD,
        "sigma_min_by_insertion": bands,
        "machine": platform.processor() or platform.machine(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "pinocchio": pin.__version__,
    }
    print(f"FK + spatial Jacobian (cp), {args.n} configurations, 1 thread: "
          f"{result['fk_plus_spatial_jacobian_configs_per_s']:,.0f} configs/s "
          f"(target {TARGET_CONFIGS_PER_S:,}: {'met' if result['meets_target'] else 'NOT met'})")
    print(f"FK only: {result['fk_only_configs_per_s']:,.0f} configs/s")
    print(f"wrench_from_torques (FK + J + batched SVD solve): "
          f"{result['wrench_from_torques_configs_per_s']:,.0f} configs/s")
    print(f"Pinocchio per-sample Python loop ({n_loop} configurations): "
          f"{result['pinocchio_per_sample_loop_configs_per_s']:,.0f} configs/s")
    for convention, rows in bands.items():
        print(f"sigma_min of J for wrench_from_torques(expressed_in={convention}) by insertion "
              f"band; damping below {DEFAULT_SIGMA_THRESHOLD:g}:")
        for band in rows:
            lo, hi = band["insertion_m"]
            print(f"  insertion [{lo:.2f}, {hi:.2f}) m, n={band['n']}: min {band['sigma_min_p0']:.2e}, "
                  f"1st pct {band['sigma_min_p1']:.2e}, median {band['sigma_min_p50']:.2e}, "
                  f"damped {100 * band['fraction_damped']:.2f} %")
    if args.json:
        write_json(args.json, result)
        print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
