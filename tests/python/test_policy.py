#!/usr/bin/python3
"""f16race.load_policy on a freshly exported smoke run, with Debian's python3-torch, and the race
example that flies it against the scripted pilot.
Usage: test_policy.py F16RACE_BINARY SMOKE_CONFIG WORK_DIR  (with PYTHONPATH=build/python)"""
import os
import shutil
import subprocess
import sys
import unittest

import numpy as np
import torch

import f16race
from f16race.policy import HL_INPUTS, LL_INPUTS

BIN, CONFIG, WORK = sys.argv[1:4]
RUN = os.path.join(WORK, "run")
EXAMPLE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "examples", "python", "race_policy.py")


def setUpModule():
    shutil.rmtree(WORK, ignore_errors=True)
    os.makedirs(WORK)
    subprocess.run([BIN, "train", "--config", CONFIG, "--run", RUN, "--max-updates", "2", "--quiet"], check=True)
    subprocess.run([BIN, "export", "--run", RUN], check=True, stdout=subprocess.DEVNULL)
    torch.set_num_threads(1)


def copies(obs, names, row_dims):
    """The inputs as tensors built from copies, [B, ...], to check the zero-copy path against."""
    return [torch.tensor(np.array(obs[k])).reshape((-1,) + obs[k].shape[obs[k].ndim - row_dims[k]:]) for k in names]


ROW_DIMS = {"ego": 1, "prev_action": 1, "goal": 1, "ado": 2, "ado_alive": 1, "task": 1}


class LoadPolicy(unittest.TestCase):
    def test_run_folder_and_export_folder(self):
        for where in (RUN, os.path.join(RUN, "export")):
            p = f16race.load_policy(where)
            self.assertEqual(os.path.abspath(p.folder), os.path.abspath(os.path.join(RUN, "export")))
            self.assertEqual(p.config_path, os.path.join(os.path.abspath(RUN), "config.yaml"))
            self.assertEqual(p.team_size, 2)  # smoke.yaml races 2 vs 2
            self.assertEqual(p.input_shapes["ado_alive"], (3,))

    def test_actions_and_bins_from_the_views(self):
        p = f16race.load_policy(RUN)
        env = p.make_env(n_env=3, seed=4)
        self.assertEqual((env.n_env, env.team_size), (3, 2))
        obs, _ = env.reset()
        for t, name in zip(p.tensors(obs, LL_INPUTS), LL_INPUTS):
            self.assertEqual(t.data_ptr(), obs[name].__array_interface__["data"][0], f"{name} was copied")
        for k in range(5):
            a = p.act(obs)
            self.assertEqual((a.dtype, a.shape), (np.float32, (3, 4, 3)))
            self.assertTrue(((a >= -1) & (a <= 1)).all())
            with torch.no_grad():
                ref = p.ll(*copies(obs, LL_INPUTS, ROW_DIMS))["action"].numpy().reshape(3, 4, 3)
            np.testing.assert_array_equal(a, ref)
            b = p.hl_bins(obs)
            self.assertEqual((b.dtype, b.shape), (np.int64, (3, 4, 3)))
            self.assertTrue(((b >= 0) & (b < env.hl_bins)).all())
            with torch.no_grad():
                ref_b = p.hl(*copies(obs, HL_INPUTS, ROW_DIMS))["bins"].numpy().reshape(3, 4, 3)
            np.testing.assert_array_equal(b, ref_b)
            env.set_hl_actions(b)
            obs, *_ = env.step(a)  # the same views, refreshed: the next act sees the new step

    def test_any_batch_shape(self):
        # The export's own example inputs are [B, ...] rows: act takes them as they are.
        p = f16race.load_policy(RUN)
        io = dict(torch.jit.load(os.path.join(RUN, "export", "example_io.pt")).named_buffers())
        obs = {k: io[k].numpy() for k in set(LL_INPUTS + HL_INPUTS)}
        a = p.act(obs)
        self.assertEqual(a.shape, (io["ego"].shape[0], 3))
        np.testing.assert_allclose(a, io["ll_mean"].clamp(-1, 1).numpy(), atol=1e-5)

    def test_refusals_are_one_line(self):
        p = f16race.load_policy(RUN)
        wrong = f16race.RaceEnv(overrides={"race.n_env": 2})  # 4 vs 4: other observation shapes
        obs, _ = wrong.reset()
        cases = [(lambda: p.act(obs), "trained for 2 vs 2"),
                 (lambda: p.act({"ego": obs["ego"]}), "no 'goal'"),
                 (lambda: f16race.load_policy(os.path.join(WORK, "missing")), "no such folder"),
                 (lambda: f16race.load_policy(WORK), "no exported policy")]
        bad = os.path.join(WORK, "bad_export")
        os.makedirs(bad, exist_ok=True)
        for f in ("hl_policy.pt", "ll_policy.pt"):
            with open(os.path.join(bad, f), "w") as out:
                out.write("not a module")
        cases.append((lambda: f16race.load_policy(bad), "cannot load it as a TorchScript module"))
        for fn, text in cases:
            with self.assertRaises(ValueError) as cm:
                fn()
            self.assertIn(text, str(cm.exception))
            self.assertEqual(len(str(cm.exception).splitlines()), 1, str(cm.exception))


class RaceExample(unittest.TestCase):
    def test_races_the_policy_against_the_scripted_pilot(self):
        out = subprocess.run([sys.executable, EXAMPLE, RUN, "--races", "3"], check=True, capture_output=True,
                             text=True).stdout
        lines = out.strip().splitlines()
        self.assertEqual(sum(1 for line in lines if line.startswith("race ")), 3, out)
        self.assertIn("of 3 races (2 vs 2)", out)
        self.assertRegex(lines[-1], r"^winner: (policy|scripted pilot|tie)$")


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0], "-v"])
