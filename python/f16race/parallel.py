"""parallel_env(): one race as a PettingZoo parallel env, observations and actions in dicts keyed by
agent name (blue_0 .. red_{k-1}). PettingZoo is not a Debian package: its ParallelEnv API is
followed by convention (reset, step, agents, possible_agents, observation_space(agent),
action_space(agent)), not imported. For many races at once, use RaceEnv and its arrays."""
import numpy as np

from . import RaceEnv
from ._core import CAUSE_NAMES, END_REASONS
from .spaces import Box, observation_boxes


class RaceParallelEnv:
    metadata = {"name": "f16race_v0", "render_modes": [], "is_parallelizable": True}
    render_mode = None

    def __init__(self, config_path=None, overrides=None):
        if isinstance(overrides, dict):
            o = dict(overrides)
        else:
            o = {s.split("=", 1)[0]: s.split("=", 1)[1] for s in (overrides or [])}
        if str(o.get("race.n_env", 1)) != "1":
            raise ValueError(f"parallel_env is one race (race.n_env 1, got {o['race.n_env']}); "
                             f"for many races use RaceEnv")
        o["race.n_env"] = 1
        self.vec = RaceEnv(config_path, overrides=o)
        self.possible_agents = self.vec.agent_names
        self.agents = []
        self._index = {name: a for a, name in enumerate(self.possible_agents)}
        self._actions = np.zeros((1, self.vec.n_agent, 3), np.float32)
        self._bins = np.full((1, self.vec.n_agent, 3), self.vec.hl_bins // 2, np.int64)
        self._obs_spaces = observation_boxes({k: s[2:] for k, s in self.vec.obs_shapes.items()})

    @property
    def num_agents(self):
        return len(self.agents)

    @property
    def max_num_agents(self):
        return len(self.possible_agents)

    def observation_space(self, agent):
        """{name: Box} of one aircraft's observation."""
        self._check_name(agent)
        return self._obs_spaces

    def action_space(self, agent):
        self._check_name(agent)
        return Box(-1.0, 1.0, (3,), "float32")

    def reset(self, seed=None, options=None):
        obs, _ = self.vec.reset(seed=seed, options=options)
        self.agents = list(self.possible_agents)
        return self._observations(obs, self.agents), {a: {} for a in self.agents}

    def step(self, actions):
        if not self.agents:
            raise RuntimeError("the race is over: call reset() before step()")
        for name in actions:
            self._check_name(name)
        missing = [a for a in self.agents if a not in actions]
        if missing:
            raise ValueError(f"step: no action for {', '.join(missing)} (every agent in .agents acts)")
        for name in self.agents:
            a = np.asarray(actions[name])
            if a.shape != (3,):
                raise ValueError(f"step: action of {name} has shape {a.shape}, expected (3,)")
            self._actions[0, self._index[name]] = a
        live = self.agents
        obs, rewards, terminated, truncated, info = self.vec.step(self._actions)
        # At the time limit the env has already started the next race; the last observations of
        # this one are in final_obs. (A race that ends otherwise leaves nothing to bootstrap from.)
        cut = truncated[0].any()
        observations = self._observations(info["final_obs"] if cut else obs, live)
        infos = {}
        done = bool(info["env_done"][0])
        winner = int(info["race_winner"][0])
        for name in live:
            a = self._index[name]
            infos[name] = {"hl_reward": float(info["hl_reward"][0, a]), "cause": CAUSE_NAMES[int(info["step_cause"][0, a])]}
            if done:
                # The env's ranks already belong to the next race; the team's final rank is the result.
                team = 0 if a < self.vec.team_size else 1
                infos[name]["team_rank"] = 0.5 if winner < 0 else float(winner != team)
                infos[name]["race_winner"] = winner
                infos[name]["race_end"] = END_REASONS[int(info["race_end"][0])]
            else:
                infos[name]["ego_rank"] = int(info["ego_rank"][0, a])
                infos[name]["team_rank"] = float(info["team_rank"][0, a])
        out = (observations,
               {n: float(rewards[0, self._index[n]]) for n in live},
               {n: bool(terminated[0, self._index[n]]) for n in live},
               {n: bool(truncated[0, self._index[n]]) for n in live},
               infos)
        self.agents = [] if done else [n for n in live if not (out[2][n] or out[3][n])]
        return out

    def hl_due(self):
        """True when the high level should choose new goals (set_hl_actions)."""
        return bool(self.vec.hl_due[0])

    def set_hl_actions(self, bins):
        """bins: {agent: 3 ints in [0, hl_bins)} for the live agents; absent agents get the middle bins."""
        self._bins[:] = self.vec.hl_bins // 2
        for name, b in bins.items():
            self._check_name(name)
            self._bins[0, self._index[name]] = np.asarray(b, dtype=np.int64)
        self.vec.set_hl_actions(self._bins)

    def render(self):
        return None

    def close(self):
        pass

    def _check_name(self, name):
        if name not in self._index:
            raise KeyError(f"no agent '{name}' (agents: {', '.join(self.possible_agents)})")

    def _observations(self, obs, names):
        # Row views of the env's buffers: per-agent dicts without a copy.
        return {n: {k: v[0, self._index[n]] for k, v in obs.items()} for n in names}


def parallel_env(config_path=None, overrides=None):
    """One race as a PettingZoo-style parallel env (see RaceParallelEnv)."""
    return RaceParallelEnv(config_path, overrides)
