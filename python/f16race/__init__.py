"""f16race from Python: the batched two-team race env, the batched AeroBench F-16 simulator and
exported policies. See docs/python.md.

    import f16race
    env = f16race.RaceEnv("configs/default.yaml", overrides={"race.n_env": 64})
    obs, info = env.reset(seed=1)
    obs, rewards, terminated, truncated, info = env.step(env.scripted_actions())

Every array the env returns is a read-only NumPy view of the env's own buffer, overwritten in
place by the next step() or reset(): copy (np.array(x)) what must outlive it. A view keeps the
env's memory alive, so it never dangles, even after the env object is gone.
"""
from ._core import (CAUSE_NAMES, END_REASONS, OUTPUT_NAMES, REF_NAMES, STATE_NAMES, STATUS_NAMES, F16Batch,
                    get_num_threads, set_num_threads, trim_level_flight)
from ._core import RaceEnv as _CoreRaceEnv
from .spaces import Box, observation_boxes


class RaceEnv(_CoreRaceEnv):
    """n_env races of team_size vs team_size aircraft, stepped together in C++.

    Gymnasium vector-env conventions (followed by convention; Gymnasium itself is not needed):
    reset(seed=None) -> (obs, info); step(actions) -> (obs, rewards, terminated, truncated, info)
    with actions float32 [n_env, n_agent, 3] and per-aircraft arrays [n_env, n_agent]. A race that
    ends restarts inside the same step (Gymnasium's same-step autoreset): info["env_done"] marks
    it, info["final_obs"] holds the last observations of races cut by the time limit.
    """

    metadata = {"autoreset_mode": "same_step", "render_modes": []}
    render_mode = None

    @property
    def agent_names(self):
        """blue_0 .. blue_{k-1}, red_0 .. red_{k-1}: agent a of every race, in the arrays' agent order."""
        k = self.team_size
        return [f"blue_{a}" for a in range(k)] + [f"red_{a}" for a in range(k)]

    @property
    def single_observation_space(self):
        """One race's observations: {name: Box [n_agent, ...]}."""
        return observation_boxes({k: s[1:] for k, s in self.obs_shapes.items()})

    @property
    def observation_space(self):
        return observation_boxes({k: s[1:] for k, s in self.obs_shapes.items()}, batch=(self.n_env,))

    @property
    def single_action_space(self):
        return Box(-1.0, 1.0, (self.n_agent, 3), "float32")

    @property
    def action_space(self):
        return Box(-1.0, 1.0, (self.n_env, self.n_agent, 3), "float32")

    @property
    def single_hl_action_space(self):
        return Box(0, self.hl_bins - 1, (self.n_agent, 3), "int64")

    def close(self):
        """Nothing to release early: the buffers go with the last view of them."""

    def __repr__(self):
        return (f"f16race.RaceEnv({self.n_env} races of {self.team_size} vs {self.team_size}, "
                f"seed {self.seed})")


from .parallel import RaceParallelEnv, parallel_env  # noqa: E402  (uses RaceEnv)
from .policy import Policy, load_policy  # noqa: E402

__all__ = ["RaceEnv", "F16Batch", "RaceParallelEnv", "parallel_env", "Policy", "load_policy", "Box",
           "trim_level_flight", "set_num_threads", "get_num_threads", "STATE_NAMES", "REF_NAMES",
           "OUTPUT_NAMES", "STATUS_NAMES", "CAUSE_NAMES", "END_REASONS"]
