#!/usr/bin/python3
"""f16race.F16Batch from Python: views of the simulator's rows, stepping, status, bad input.
Usage: test_f16batch.py  (with PYTHONPATH=build/python)"""
import gc
import sys
import unittest

import numpy as np

import f16race

VT, ALPHA, PSI, ALT = (f16race.STATE_NAMES.index(n) for n in ("vt_ftps", "alpha_rad", "psi_rad", "alt_ft"))


class Views(unittest.TestCase):
    def test_rows_cover_the_real_aircraft(self):
        sim = f16race.F16Batch(n_env=5, n_agent=4)  # 20 aircraft, padded to 32 lanes inside
        self.assertEqual(sim.size, 20)
        self.assertEqual(sim.state.shape, (16, 20))
        self.assertEqual(sim.ref.shape, (4, 20))
        self.assertEqual(sim.output.shape, (10, 20))
        self.assertEqual(sim.status.shape, (20,))
        self.assertEqual(sim.state.strides, (32 * 8, 8))  # one padded row per state, no copy
        self.assertTrue(sim.state.flags.writeable and sim.ref.flags.writeable)
        self.assertFalse(sim.output.flags.writeable or sim.status.flags.writeable)
        self.assertTrue((sim.status == 0).all())
        with self.assertRaises(ValueError):
            sim.law  # only with a stage law
        self.assertEqual(f16race.F16Batch(2, 1, stage_law="gcas").law.shape, (5, 2))

    def test_writes_through_the_view_reach_the_simulator(self):
        x0, u0 = f16race.trim_level_flight(600.0, 8000.0)
        sim = f16race.F16Batch(n_env=3, n_agent=1)
        state, ref = sim.state, sim.ref
        state[:, :] = x0[:, None]
        ref[:, :] = u0[:, None]
        state[PSI, 1] = 0.5  # heading does not change the trim
        state[ALT, 2] = 12000.0  # off-trim altitude: it will drift
        sim.step(0.01, 100)
        self.assertLess(abs(state[VT, 0] - 600.0), 1e-6)
        self.assertLess(abs(state[ALT, 0] - 8000.0), 1e-3)
        np.testing.assert_allclose(state[VT, 1], state[VT, 0], rtol=0, atol=1e-9)
        self.assertGreater(abs(state[VT, 2] - 600.0), 1e-3)

    def test_lanes_are_independent_and_bit_identical(self):
        x0, u0 = f16race.trim_level_flight(540.0, 5000.0)
        one = f16race.F16Batch(1, 1)
        many = f16race.F16Batch(7, 3)
        one.reset_aircraft(0, x0, u0)
        for i in range(many.size):
            x = x0.copy()
            x[PSI] = 0.1 * i
            many.reset_aircraft(i, x, u0)
        many.reset_aircraft(13, x0, u0)  # the same start as `one`, in another lane of another block
        for batch in (one, many):
            batch.ref[0, :] = 2.0  # a 2 g pull for 3 s
            batch.step(0.01, 300)
        np.testing.assert_array_equal(many.state[:, 13], one.state[:, 0])

    def test_frozen_aircraft_and_outputs(self):
        x0, u0 = f16race.trim_level_flight()
        sim = f16race.F16Batch(2, 2)
        for i in range(4):
            sim.reset_aircraft(i, x0, u0)
        sim.state[ALPHA, 2] = 1.0  # beyond the 45 deg table range
        self.assertEqual(sim.step(0.01, 10), 1)
        self.assertEqual([f16race.STATUS_NAMES[s] for s in sim.status], ["ok", "ok", "alpha_limit", "ok"])
        self.assertEqual(sim.state[ALPHA, 2], 1.0)  # frozen at its last valid state
        self.assertEqual(sim.step(0.01, 10), 0)  # frozen ones are not counted again
        sim.evaluate_outputs()
        nz = sim.output[f16race.OUTPUT_NAMES.index("Nz_g")]
        self.assertLess(abs(nz[0]), 1e-2)  # level trim: AeroBench's Nz excludes gravity
        vn = sim.output[f16race.OUTPUT_NAMES.index("vn_ftps")]
        self.assertAlmostEqual(vn[0], 540.0, delta=1.0)  # heading north at the trim speed
        sim.reset_aircraft(2, x0, u0)
        self.assertEqual(sim.status[2], 0)

    def test_views_outlive_the_batch(self):
        sim = f16race.F16Batch(2, 2)
        state = sim.state
        before = state.copy()
        del sim
        gc.collect()
        np.testing.assert_array_equal(state, before)


class BadInput(unittest.TestCase):
    def check(self, kind, fn, text):
        with self.assertRaises(kind) as cm:
            fn()
        self.assertIn(text, str(cm.exception))
        self.assertEqual(len(str(cm.exception).splitlines()), 1)

    def test_refused_in_one_line(self):
        sim = f16race.F16Batch(1, 2)
        self.check(ValueError, lambda: sim.step(0.0), "dt_s must be finite and > 0")
        self.check(ValueError, lambda: sim.step(float("nan")), "dt_s")
        self.check(ValueError, lambda: sim.step(0.01, 0), "substeps must be >= 1")
        self.check(IndexError, lambda: sim.reset_aircraft(2, np.zeros(16), np.zeros(4)), "not in [0, 2)")
        self.check(ValueError, lambda: sim.reset_aircraft(0, np.zeros(15), np.zeros(4)), "16 numbers")
        self.check(ValueError, lambda: f16race.F16Batch(0, 1), "must be >= 1")
        self.check(ValueError, lambda: f16race.F16Batch(1, 1, model="boeing"), "morelli or stevens")
        self.check(ValueError, lambda: f16race.F16Batch(1, 1, integrator="rk45"), "rk4 or euler")
        self.check(ValueError, lambda: f16race.trim_level_flight(60.0, 5000.0), "")  # too slow to fly level
        self.assertEqual(sim.step(0.01, 1), 0)  # still usable


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0], "-v"])
