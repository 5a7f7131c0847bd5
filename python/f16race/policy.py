"""load_policy: the TorchScript policies written by `f16race export`, run with plain PyTorch on a
RaceEnv's observations. The observation views become tensors with torch.from_numpy (no copy)."""
import os
import warnings

import numpy as np

LL_INPUTS = ("ego", "goal", "ado", "ado_alive", "task")
HL_INPUTS = ("ego", "prev_action", "ado", "ado_alive", "task")


class Policy:
    """An exported policy pair: ll (actions every LL step) and hl (goal bins every HL interval).

    Observations are the env's dict of arrays [n_env, n_agent, ...] (or any [..., per-aircraft]
    batch of them); every aircraft row is one policy input (decentralised execution).
    """

    def __init__(self, folder, config_path=None):
        import torch
        self._torch = torch
        self.folder = folder
        self.config_path = config_path  # the run's config.yaml when known, else None
        self.hl = _load_module(torch, os.path.join(folder, "hl_policy.pt"))
        self.ll = _load_module(torch, os.path.join(folder, "ll_policy.pt"))
        # Per-aircraft input shapes, from the export's own example inputs (when present).
        self.input_shapes = {}
        example = os.path.join(folder, "example_io.pt")
        if os.path.isfile(example):
            io = dict(_load_module(torch, example).named_buffers())
            self.input_shapes = {k: tuple(io[k].shape[1:]) for k in set(LL_INPUTS + HL_INPUTS)}

    @property
    def team_size(self):
        """Aircraft per team the policy was trained for (from its ado input), or None if unknown."""
        ado = self.input_shapes.get("ado")
        return None if ado is None else (ado[0] + 1) // 2

    def make_env(self, n_env, seed=None, overrides=None, config_path=None):
        """A RaceEnv this policy can fly: config_path, else its run's config (when known), else the
        built-in defaults at the policy's team size; n_env races."""
        from . import RaceEnv
        config_path = config_path if config_path is not None else self.config_path
        o = dict(overrides or {})
        o["race.n_env"] = n_env
        if seed is not None:
            o["race.seed"] = seed
        if config_path is None and self.team_size is not None:
            o.setdefault("race.team_size", self.team_size)
        return RaceEnv(config_path, overrides=o)

    def tensors(self, obs, names):
        """The inputs `names` as tensors [B, ...] that share memory with the arrays in `obs`."""
        return self._inputs(obs, names)[0]

    def _inputs(self, obs, names):
        """(tensors [B, ...], the batch shape of obs) for the inputs `names`."""
        batch = None
        out = []
        for name in names:
            if name not in obs:
                raise ValueError(f"observations have no '{name}' (keys: {', '.join(obs)})")
            a = obs[name]
            want = self.input_shapes.get(name)
            per_row = a.ndim - (2 if name == "ado" else 1)  # batch dims: all but the input's row dims
            if want is not None and tuple(a.shape[per_row:]) != want:
                raise ValueError(f"observation '{name}' has rows of shape {tuple(a.shape[per_row:])}, the policy in "
                                 f"{self.folder} takes {want} (trained for {self.team_size} vs {self.team_size}; "
                                 f"build the env from its config or with race.team_size)")
            if batch is None:
                batch = a.shape[:per_row]
            elif a.shape[:per_row] != batch:
                raise ValueError(f"observation '{name}' has batch shape {a.shape[:per_row]}, others {batch}")
            with warnings.catch_warnings():
                # The env's views are read-only; the policies only read them.
                warnings.filterwarnings("ignore", message="The given NumPy array is not writable")
                t = self._torch.from_numpy(a)
            out.append(t.reshape((-1,) + tuple(a.shape[per_row:])))
        return out, batch

    def act(self, obs):
        """Greedy LL actions, float32 [*batch, 3] in [-1, 1] (what the env applies)."""
        inputs, batch = self._inputs(obs, LL_INPUTS)
        with self._torch.no_grad():
            a = self.ll(*inputs)["action"]
        return a.numpy().reshape(batch + (3,))

    def hl_bins(self, obs):
        """Greedy HL goal bins, int64 [*batch, 3] (for RaceEnv.set_hl_actions)."""
        inputs, batch = self._inputs(obs, HL_INPUTS)
        with self._torch.no_grad():
            b = self.hl(*inputs)["bins"]
        return b.numpy().reshape(batch + (3,))

    __call__ = act

    def __repr__(self):
        return f"f16race.Policy({self.folder!r}, {self.team_size} vs {self.team_size})"


def _load_module(torch, path):
    try:
        return torch.jit.load(path, map_location="cpu")
    except RuntimeError as e:
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise ValueError(f"{path}: cannot load it as a TorchScript module ({first})") from None


def load_policy(run_or_export_dir):
    """The policy in an `f16race export` folder, or in RUN/export for a training run folder RUN."""
    d = os.fspath(run_or_export_dir)
    if not os.path.isdir(d):
        raise ValueError(f"{d}: no such folder (give a run folder or an `f16race export` folder)")
    for folder in (d, os.path.join(d, "export")):
        if all(os.path.isfile(os.path.join(folder, f)) for f in ("hl_policy.pt", "ll_policy.pt")):
            break
    else:
        raise ValueError(f"{d}: no exported policy (hl_policy.pt and ll_policy.pt, here or in {d}/export); "
                         f"write one with `f16race export --run RUN`")
    # The run's config, when this is RUN/export of a run folder: the env the policy was trained in.
    run = os.path.dirname(os.path.abspath(folder))
    config = os.path.join(run, "config.yaml")
    if os.path.basename(os.path.abspath(folder)) != "export" or not os.path.isdir(os.path.join(run, "checkpoint")) \
            or not os.path.isfile(config):
        config = None
    return Policy(folder, config)
