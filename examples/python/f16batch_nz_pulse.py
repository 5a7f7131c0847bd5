#!/usr/bin/python3
"""AeroBench's `b_nz_pulse` scenario flown by f16race.F16Batch from Python, compared with AeroBench.

The reference file (tests/data/b_nz_pulse_morelli.csv, AeroBench's own run at 1e-12 tolerance)
gives the start state and the outer-loop references every 0.02 s. Each reference is held over
its interval (exact for these step inputs) and integrated by RK4 at 0.01 s, as
tests/dynamics/test_trajectories.cpp does in C++; the tolerances are that test's.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/f16batch_nz_pulse.py [--model stevens]
"""
import argparse
import csv
import os
import sys

import numpy as np

import f16race

TOLERANCE = {"vt": 0.05, "angles": 1e-4, "position": 1.0}  # ft/s, rad, ft


def load(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0] if k != "mode"}


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", choices=["morelli", "stevens"], default="morelli")
    p.add_argument("--reference", help="AeroBench CSV (default: tests/data/b_nz_pulse_MODEL.csv)")
    p.add_argument("--dt", type=float, default=0.01, help="RK4 step [s]")
    a = p.parse_args()
    path = a.reference or os.path.join(here, "..", "..", "tests", "data", f"b_nz_pulse_{a.model}.csv")
    ref = load(path)
    t = ref["t_s"]

    sim = f16race.F16Batch(n_env=1, n_agent=1, model=a.model)
    sim.reset_aircraft(0, [ref[n][0] for n in f16race.STATE_NAMES], [ref[n][0] for n in f16race.REF_NAMES])
    x = sim.state  # [16, 1] view of the simulator's states: it follows every step
    flown = np.empty((len(t), len(f16race.STATE_NAMES)))
    flown[0] = x[:, 0]
    for k in range(len(t) - 1):
        sim.ref[:, 0] = [ref[n][k] for n in f16race.REF_NAMES]  # held over [t_k, t_k+1)
        substeps = max(1, round((t[k + 1] - t[k]) / a.dt))
        if sim.step((t[k + 1] - t[k]) / substeps, substeps) != 0:
            sys.exit(f"aircraft left the envelope at t = {t[k + 1]:.2f} s: {f16race.STATUS_NAMES[sim.status[0]]}")
        flown[k + 1] = x[:, 0]

    err = {n: np.abs(flown[:, i] - ref[n]).max() for i, n in enumerate(f16race.STATE_NAMES)}
    worst = {"vt": err["vt_ftps"],
             "angles": max(err[n] for n in ("alpha_rad", "beta_rad", "phi_rad", "theta_rad", "psi_rad")),
             "position": max(err[n] for n in ("pn_ft", "pe_ft", "alt_ft"))}
    print(f"b_nz_pulse ({a.model}): {len(t)} samples over {t[-1]:.1f} s, RK4 at {a.dt} s, "
          f"Nz_ref from {ref['Nz_ref_g'].min():.2f} to {ref['Nz_ref_g'].max():.2f} g")
    print(f"final state: vt {flown[-1, 0]:.3f} ft/s, alt {flown[-1, 11]:.2f} ft "
          f"(AeroBench {ref['vt_ftps'][-1]:.3f}, {ref['alt_ft'][-1]:.2f})")
    ok = True
    for what, e in worst.items():
        ok &= e < TOLERANCE[what]
        print(f"max |error| {what:<8} {e:.3e} (tolerance {TOLERANCE[what]:g})")
    print("within AeroBench tolerances" if ok else "OUTSIDE AeroBench tolerances")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
