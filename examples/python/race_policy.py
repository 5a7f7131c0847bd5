#!/usr/bin/python3
"""Race an exported policy (blue) against the scripted pilot (red) in the Python env.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/race_policy.py RUN_OR_EXPORT_DIR [--races 16]
"""
import argparse

import numpy as np

import f16race

p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
p.add_argument("policy", help="a training run folder (uses RUN/export) or an `f16race export` folder")
p.add_argument("--races", type=int, default=16)
p.add_argument("--seed", type=int, default=1)
a = p.parse_args()

policy = f16race.load_policy(a.policy)
env = policy.make_env(n_env=a.races, seed=a.seed)  # the run's config, so the observations match
obs, info = env.reset()
red = slice(env.team_size, None)
winner = np.full(env.n_env, -2)  # -2: first race still running; then 0 blue, 1 red, -1 draw
while (winner == -2).any():
    if env.hl_due.any():
        env.set_hl_actions(policy.hl_bins(obs))  # goals for the envs that are due; red ignores them
    actions = policy.act(obs)
    actions[:, red] = env.scripted_actions()[:, red]
    obs, rewards, terminated, truncated, info = env.step(actions)
    first = info["env_done"] & (winner == -2)  # finished races restart at once: keep each env's first
    winner[first] = info["race_winner"][first]
    for e in np.flatnonzero(first):
        print(f"race {e:2d}: {['draw', 'blue (policy)', 'red (scripted)'][winner[e] + 1]} "
              f"by {f16race.END_REASONS[info['race_end'][e]]}")
blue, red_wins, draws = (winner == 0).sum(), (winner == 1).sum(), (winner == -1).sum()
print(f"{policy.folder}: policy won {blue}, scripted pilot won {red_wins}, {draws} draws of {env.n_env} races "
      f"({env.team_size} vs {env.team_size})")
print("winner:", "policy" if blue > red_wins else "scripted pilot" if red_wins > blue else "tie")
