#!/usr/bin/python3
"""f16race.RaceEnv and parallel_env from Python (Debian's python3 and NumPy, unittest).

Usage: test_race_env.py RACE_ENV_DUMP CONFIG WORK_DIR  (with PYTHONPATH=build/python)
RACE_ENV_DUMP is tests/python/race_env_dump.cpp: the C++ env stepped with the same actions, whose
arrays the Python env must reproduce byte for byte.
"""
import gc
import os
import struct
import subprocess
import sys
import unittest

import numpy as np

import f16race

DUMP, CONFIG, WORK = sys.argv[1:4]
# Small and eventful: 8 s races cut by the time limit (truncations, final_* observations), red
# flying a fixed action pattern (terminations), a goal every 2 s.
OVERRIDES = {"race.n_env": 6, "race.team_size": 2, "race.time_limit_s": 8.0, "race.time_limit_terminal": False,
             "race.dt_hl_s": 2.0}
STEPS = 250
OBS = ("ego", "prev_action", "goal", "ado", "ado_alive", "task")


def cpp_records(seed, steps=STEPS):
    """{name: bytes} of race_env_dump's run at `seed`."""
    os.makedirs(WORK, exist_ok=True)
    path = os.path.join(WORK, f"dump_seed{seed}.bin")
    sets = [f"{k}={str(v).lower() if isinstance(v, bool) else v}" for k, v in OVERRIDES.items()]
    subprocess.run([DUMP, CONFIG, str(seed), str(steps), path] + sets, check=True)
    records = {}
    with open(path, "rb") as f:
        data = f.read()
    at = 0
    while at < len(data):
        (n,) = struct.unpack_from("<I", data, at)
        name = data[at + 4:at + 4 + n].decode()
        (size,) = struct.unpack_from("<Q", data, at + 4 + n)
        records[name] = data[at + 12 + n:at + 12 + n + size]
        at += 12 + n + size
    return records


def actions_at(env, k):
    """race_env_dump's actions for step k: scripted blue, a fixed pattern for red."""
    a = env.scripted_actions()
    f = np.arange(a.size).reshape(a.shape)
    pattern = ((7 * k + 13 * f) % 21 - 10).astype(np.float32) / np.float32(20.0)
    a[:, env.team_size:] = pattern[:, env.team_size:]
    return a


def bins_at(env, k):
    return ((k + np.arange(env.n_env * env.n_agent * 3)) % env.hl_bins).reshape(env.n_env, env.n_agent, 3).astype(np.int64)


def state_records(k, obs, info):
    r = {f"{k}/{name}": obs[name] for name in OBS}
    for name in ("hl_due", "alive", "ego_rank", "team_rank"):
        r[f"{k}/{name}"] = info[name]
    return r


def step_records(k, env, rewards, terminated, truncated, info):
    r = {f"{k}/ll_reward": rewards, f"{k}/hl_reward": info["hl_reward"], f"{k}/acted": info["acted"],
         f"{k}/terminated": terminated, f"{k}/truncated": truncated, f"{k}/step_cause": info["step_cause"],
         f"{k}/env_done": info["env_done"], f"{k}/race_winner": info["race_winner"], f"{k}/race_end": info["race_end"]}
    s = info["stats"]
    r[f"{k}/stats"] = np.array(
        [s["terminations"][c] for c in f16race.CAUSE_NAMES[1:]] +
        [s[n] for n in ("races_finished", "races_won_blue", "races_won_red", "races_drawn", "races_by_finish_line",
                        "races_by_elimination", "races_by_time_limit", "aircraft_alive_at_end")], np.int32)
    for e in np.flatnonzero(truncated.any(axis=1)):
        for name in OBS:
            r[f"{k}/final_{name}/{e}"] = info["final_obs"][name][e]
    return r


def run_python(env, steps=STEPS, first=None):
    """Steps env as race_env_dump does; returns {name: array copy} in the dump's naming."""
    obs, info = first if first is not None else env.reset()
    out = {k: np.array(v) for k, v in state_records(0, obs, info).items()}
    for k in range(1, steps + 1):
        env.set_hl_actions(bins_at(env, k))
        obs, rewards, terminated, truncated, info = env.step(actions_at(env, k))
        rec = step_records(k, env, rewards, terminated, truncated, info)
        rec.update(state_records(k, obs, info))
        out.update({name: np.array(v) for name, v in rec.items()})
    return out


class SameArraysAsCpp(unittest.TestCase):
    def compare(self, cpp, py):
        self.assertEqual(sorted(cpp), sorted(py), "different arrays recorded")
        for name in cpp:  # in the order written: the first difference is the one to look at
            a = py[name]
            b = np.frombuffer(cpp[name], dtype=a.dtype).reshape(a.shape)
            if a.tobytes() != cpp[name]:
                where = np.argwhere(a != b)[0]
                self.fail(f"{name} differs at {tuple(where)}: python {a[tuple(where)]!r}, C++ {b[tuple(where)]!r}")

    def test_same_seed_same_arrays(self):
        env = f16race.RaceEnv(CONFIG, overrides=dict(OVERRIDES, **{"race.seed": 11}))
        f16race.set_num_threads(2)  # the C++ run has one thread: results do not depend on it
        try:
            py = run_python(env)
        finally:
            f16race.set_num_threads(1)
        cpp = cpp_records(11)
        self.compare(cpp, py)
        # The run is eventful enough to check the arrays it compares.
        ends = [n for n in py if n.endswith("/race_end")]
        self.assertGreater(sum(int(py[n.replace("race_end", "env_done")].sum()) for n in ends), 6)
        self.assertTrue(any("/final_ego/" in n for n in py), "no time-limit truncation in the run")
        self.assertGreater(sum(int(py[n].sum()) for n in py if n.endswith("/terminated")), 0)

    def test_reset_with_seed_is_a_fresh_env(self):
        env = f16race.RaceEnv(CONFIG, overrides=dict(OVERRIDES, **{"race.seed": 5}))
        env.reset()
        for k in range(1, 40):
            env.step(actions_at(env, k))
        first = env.reset(seed=np.int64(23))  # any integer, NumPy's too
        self.assertEqual(env.seed, 23)
        self.compare(cpp_records(23, steps=60), run_python(env, steps=60, first=first))

    def test_reset_without_seed_starts_new_races(self):
        env = f16race.RaceEnv(CONFIG, overrides=OVERRIDES)
        obs, _ = env.reset()
        first = np.array(obs["task"])
        obs, _ = env.reset()  # the first reset kept the constructor's races; this one draws new tracks
        self.assertFalse(np.array_equal(first, obs["task"]))
        twin = f16race.RaceEnv(CONFIG, overrides=OVERRIDES)
        twin.reset()
        np.testing.assert_array_equal(twin.reset()[0]["task"], obs["task"])


class Views(unittest.TestCase):
    def test_views_stay_valid_across_steps(self):
        env = f16race.RaceEnv(CONFIG, overrides=OVERRIDES)
        obs, info = env.reset()
        ego, alive, rank = obs["ego"], info["alive"], info["ego_rank"]
        address = ego.__array_interface__["data"][0]
        before = np.array(ego)
        for k in range(1, 30):
            obs2, rewards, terminated, truncated, info2 = env.step(actions_at(env, k))
            # The same memory, overwritten in place: no copy per step.
            self.assertIs(obs2["ego"], ego)
            self.assertEqual(obs2["ego"].__array_interface__["data"][0], address)
            self.assertIs(info2["alive"], alive)
            self.assertIs(info2["ego_rank"], rank)
        self.assertFalse(np.array_equal(before, ego), "the view did not follow the env")
        for a in list(obs2.values()) + [rewards, terminated, truncated, info2["hl_reward"], info2["team_rank"]]:
            self.assertFalse(a.flags.writeable)
            self.assertFalse(a.flags.owndata)
            self.assertTrue(a.flags.c_contiguous)
        with self.assertRaises(ValueError):
            ego[0, 0, 0] = 1.0
        # A view keeps the env's memory: it outlives the env object.
        last = np.array(ego)
        del env, obs, obs2, info, info2
        gc.collect()
        np.testing.assert_array_equal(ego, last)
        self.assertEqual(float(np.abs(ego).sum()), float(np.abs(last).sum()))

    def test_dtypes_and_shapes(self):
        env = f16race.RaceEnv(CONFIG, overrides=OVERRIDES)
        obs, info = env.reset()
        n, a = env.n_env, env.n_agent
        self.assertEqual((n, a), (6, 4))
        self.assertEqual(obs["ado"].shape[:3], (n, a, a - 1))
        self.assertEqual(obs["ado_alive"].dtype, np.bool_)
        self.assertTrue(obs["ado_alive"].all())
        for k in OBS:
            self.assertEqual(obs[k].shape, env.obs_shapes[k])
            self.assertTrue(env.single_observation_space[k].shape == obs[k].shape[1:])
        _, r, te, tr, info = env.step(env.scripted_actions())
        self.assertEqual((r.dtype, te.dtype, tr.dtype), (np.float32, np.bool_, np.bool_))
        self.assertEqual(r.shape, (n, a))
        self.assertEqual(info["hl_due"].shape, (n,))
        self.assertTrue(env.action_space.contains(env.scripted_actions()))
        self.assertEqual(env.config["n_env"], 6)
        self.assertIs(env.config["time_limit_terminal"], False)


class BadInput(unittest.TestCase):
    def assert_one_line(self, kind, fn, *words):
        with self.assertRaises(kind) as cm:
            fn()
        msg = str(cm.exception)
        self.assertEqual(len(msg.splitlines()), 1, msg)
        for w in words:
            self.assertIn(w, msg)
        return msg

    def test_bad_actions_are_refused_and_the_env_goes_on(self):
        env = f16race.RaceEnv(CONFIG, overrides=OVERRIDES)
        twin = f16race.RaceEnv(CONFIG, overrides=OVERRIDES)
        env.reset()
        twin.reset()
        good = actions_at(env, 1)
        nan = good.copy()
        nan[2, 1, 0] = np.nan
        inf = good.copy()
        inf[5, 3, 2] = -np.inf
        one = self.assert_one_line
        one(ValueError, lambda: env.step(good[:, :3]), "shape (6, 3, 3)", "expected (6, 4, 3)")
        one(ValueError, lambda: env.step(good.reshape(-1)), "shape (72,)")
        one(TypeError, lambda: env.step(good.astype(np.float64)), "float64", "float32")
        one(TypeError, lambda: env.step(good.tolist()), "list", "numpy.ndarray")
        one(ValueError, lambda: env.step(nan), "actions[2, 1, 0] is nan", "finite")
        one(ValueError, lambda: env.step(inf), "actions[5, 3, 2] is -inf")
        one(ValueError, lambda: env.step(np.asfortranarray(good)), "C-contiguous")
        bins = bins_at(env, 1)
        one(TypeError, lambda: env.set_hl_actions(bins.astype(np.int32)), "int32", "int64")
        high = bins.copy()
        high[1, 2, 1] = env.hl_bins
        one(ValueError, lambda: env.set_hl_actions(high), "bins[1, 2, 1] is 7", "[0, 7)")
        one(ValueError, lambda: env.set_hl_actions(bins[:1]), "shape (1, 4, 3)")
        one(ValueError, lambda: env.reset(seed=-1), "not in [0, 2**64)")
        one(TypeError, lambda: env.reset(seed=[1, 2]), "one int")
        # Nothing of the refused calls reached the env: it goes on exactly as its twin.
        for k in range(1, 20):
            out = []
            for e in (env, twin):
                e.set_hl_actions(bins_at(e, k))
                obs, r, te, tr, info = e.step(actions_at(e, k))
                out.append([np.array(x) for x in (obs["ego"], obs["task"], obs["prev_action"], r, te)])
            for mine, theirs in zip(*out):
                np.testing.assert_array_equal(mine, theirs)
        self.assertTrue(np.isfinite(env.observations["ego"]).all())

    def test_bad_configs_are_one_line_value_errors(self):
        one = self.assert_one_line
        one(ValueError, lambda: f16race.RaceEnv(CONFIG, overrides={"race.n_envv": 4}), "unknown key", "n_envv")
        one(ValueError, lambda: f16race.RaceEnv(overrides={"race.n_env": 0}), "race.n_env", "out of range")
        one(ValueError, lambda: f16race.RaceEnv(overrides={"race.model": "boeing"}), "model")
        one(ValueError, lambda: f16race.RaceEnv(overrides={"n_env": 4}), "race.n_env")
        one(ValueError, lambda: f16race.RaceEnv(overrides=["race.n_env=[1"]), "not valid YAML")
        one(TypeError, lambda: f16race.RaceEnv(overrides={"race.n_env": object()}), "race.n_env")
        one(ValueError, lambda: f16race.RaceEnv(os.path.join(WORK, "no_such.yaml")), "no_such.yaml", "cannot open")
        one(ValueError, lambda: f16race.RaceEnv(overrides={"race.dt_hl_s": 600.0}), "dt_hl_s")

    def test_the_default_race_is_the_default_config(self):
        self.assertEqual(f16race.RaceEnv().config, f16race.RaceEnv(CONFIG).config)

    def test_a_run_folders_older_config_reads_with_the_defaults_of_its_time(self):
        # A run folder's config.yaml without config_version (version 1): a key it does not list
        # had that version's default (time_limit_s 120), not today's (60).
        run = os.path.join(WORK, "v1_run")
        os.makedirs(os.path.join(run, "checkpoint"), exist_ok=True)
        with open(os.path.join(run, "config.yaml"), "w") as f:
            f.write("seed: 1\nrace: {n_env: 2, lane_error_average_s: 0}\n")
        self.assertEqual(f16race.RaceEnv(os.path.join(run, "config.yaml")).config["time_limit_s"], 120.0)
        user = os.path.join(WORK, "v1_user.yaml")
        with open(user, "w") as f:
            f.write("seed: 1\nrace: {n_env: 2}\n")
        self.assertEqual(f16race.RaceEnv(user).config["time_limit_s"], 60.0)


class HighLevelAndRanks(unittest.TestCase):
    def test_hl_due_cycle(self):
        env = f16race.RaceEnv(CONFIG, overrides=OVERRIDES)
        obs, info = env.reset()
        self.assertTrue(env.hl_due.all())
        goal = np.array(obs["goal"])
        bins = np.zeros((env.n_env, env.n_agent, 3), np.int64)  # the outer bins: far from the center-line
        env.set_hl_actions(bins)
        self.assertFalse(env.hl_due.any())
        self.assertFalse(np.array_equal(goal, obs["goal"]), "new goals not observed")
        interval = round(env.dt_hl_s / env.dt_ll_s)
        for k in range(interval - 1):
            env.step(env.scripted_actions())
            self.assertFalse(env.hl_due.any(), f"due after {k + 1} steps")
        env.step(env.scripted_actions())
        self.assertTrue(env.hl_due.all(), f"not due after {interval} steps ({env.dt_hl_s} s)")

    def test_ranks_follow_progress(self):
        env = f16race.RaceEnv(CONFIG, overrides=OVERRIDES)
        env.reset()
        for k in range(1, 60):
            env.step(actions_at(env, k))
            prog, alive = env.progress_ft, env.alive
            for e in range(env.n_env):
                for a in range(env.n_agent):
                    # Aircraft strictly ahead: live ones further along, and every live one for a dead a.
                    ahead = sum(1 for b in range(env.n_agent)
                                if (alive[e, b] and (not alive[e, a] or prog[e, b] > prog[e, a]))
                                or (not alive[e, b] and not alive[e, a] and prog[e, b] > prog[e, a]))
                    self.assertEqual(env.ego_rank[e, a], ahead, f"step {k}, env {e}, agent {a}")
            t = env.team_rank
            k2 = env.team_size
            self.assertTrue(np.isin(t, [0.0, 0.5, 1.0]).all())
            np.testing.assert_array_equal(t[:, 0] + t[:, k2], np.ones(env.n_env))  # zero-sum between teams
            self.assertTrue((t[:, :k2] == t[:, :1]).all() and (t[:, k2:] == t[:, k2:k2 + 1]).all())


class ParallelEnv(unittest.TestCase):
    def test_per_agent_dicts_match_the_vector_env(self):
        o = {k: v for k, v in OVERRIDES.items() if k != "race.n_env"}
        o["race.seed"] = 4
        pz = f16race.parallel_env(CONFIG, overrides=o)
        vec = f16race.RaceEnv(CONFIG, overrides=dict(o, **{"race.n_env": 1}))
        self.assertEqual(pz.possible_agents, ["blue_0", "blue_1", "red_0", "red_1"])
        obs, infos = pz.reset()
        vobs, _ = vec.reset()
        self.assertEqual(sorted(obs), sorted(pz.possible_agents))
        self.assertEqual(pz.action_space("red_1").shape, (3,))
        self.assertEqual(pz.observation_space("blue_0")["ado"].shape, vobs["ado"].shape[2:])
        steps, ended = 0, False
        while pz.agents:
            if pz.hl_due():
                pz.set_hl_actions({n: [k % 7, 3, (k + 2) % 7] for k, n in enumerate(pz.agents)})
                bins = np.full((1, 4, 3), 3, np.int64)
                for k, n in enumerate(pz.agents):
                    bins[0, pz.possible_agents.index(n)] = [k % 7, 3, (k + 2) % 7]
                vec.set_hl_actions(bins)
            acts = actions_at(vec, steps + 1)
            live = list(pz.agents)
            obs, rew, term, trunc, infos = pz.step({n: acts[0, pz.possible_agents.index(n)] for n in live})
            vobs, vrew, vterm, vtrunc, vinfo = vec.step(acts)
            steps += 1
            self.assertEqual(sorted(obs), sorted(live))
            for n in live:
                a = pz.possible_agents.index(n)
                self.assertEqual(rew[n], float(vrew[0, a]))
                self.assertEqual(term[n], bool(vterm[0, a]))
                self.assertEqual(trunc[n], bool(vtrunc[0, a]))
                self.assertEqual(infos[n]["hl_reward"], float(vinfo["hl_reward"][0, a]))
                if vinfo["env_done"][0]:  # the team's result, not the next race's ranks
                    w = int(vinfo["race_winner"][0])
                    self.assertEqual(infos[n]["race_winner"], w)
                    self.assertEqual(infos[n]["team_rank"], 0.5 if w < 0 else float(w != (a >= 2)))
                    self.assertNotIn("ego_rank", infos[n])
                else:
                    self.assertEqual(infos[n]["ego_rank"], int(vinfo["ego_rank"][0, a]))
                cut = vtrunc[0].any()
                src = vinfo["final_obs"] if cut else vobs
                own = pz.vec.final_observations if cut else pz.vec.observations
                for k in OBS:
                    np.testing.assert_array_equal(obs[n][k], src[k][0, a])
                    self.assertTrue(np.shares_memory(obs[n][k], own[k]))  # a row view, no copy
            ended = bool(vinfo["env_done"][0])
            self.assertEqual(set(pz.agents), {n for n in live if not (term[n] or trunc[n])} if not ended else set())
        self.assertTrue(ended)
        end = f16race.END_REASONS[int(vinfo["race_end"][0])]
        if end == "time limit":
            self.assertEqual(steps, round(8.0 / 0.08))
            self.assertTrue(all(trunc.values()) and infos[live[0]]["race_end"] == "time limit")
        else:
            self.assertLess(steps, round(8.0 / 0.08), end)
        with self.assertRaises(RuntimeError):
            pz.step({})
        obs, _ = pz.reset()
        self.assertEqual(len(pz.agents), 4)
        with self.assertRaises(ValueError):
            pz.step({"blue_0": np.zeros(3, np.float32)})  # the other live agents have no action
        with self.assertRaises(KeyError):
            pz.step({n: np.zeros(3, np.float32) for n in pz.agents + ["green_0"]})
        with self.assertRaises(ValueError):
            f16race.parallel_env(CONFIG, overrides={"race.n_env": 4})


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0], "-v"])
