#!/usr/bin/python3
"""Loads an `f16race export` folder with plain PyTorch (no f16race code) and checks the modules
against the in-process outputs stored in example_io.pt, then on inputs of another batch size.
Usage: check_export.py EXPORT_DIR   (exit 0 when every check holds)"""
import sys

import torch


TOL = 1e-4  # |exported - in-process| / max(1, |in-process|): the same functions summed in another order


def scaled_diff(a, ref):
    return ((a.double() - ref.double()).abs() / ref.double().abs().clamp(min=1.0)).max().item()


def main(folder):
    hl = torch.jit.load(f"{folder}/hl_policy.pt")
    ll = torch.jit.load(f"{folder}/ll_policy.pt")
    io = dict(torch.jit.load(f"{folder}/example_io.pt").named_buffers())
    with torch.no_grad():
        h = hl(io["ego"], io["prev_action"], io["ado"], io["ado_alive"], io["task"])
        l = ll(io["ego"], io["goal"], io["ado"], io["ado_alive"], io["task"])
    worst = 0.0
    for key, ref in [("q", io["hl_q"]), ("probs", io.get("hl_probs"))]:
        if ref is None:
            assert key not in h, f"hl output {key} present but no reference"
            continue
        worst = max(worst, scaled_diff(h[key], ref))
    for key in ["mean", "log_std", "value"]:
        worst = max(worst, scaled_diff(l[key], io["ll_" + key]))
    # A greedy bin may differ only where the in-process Q of the two bins tie (float rounding of
    # another summation order picks either of two equal values).
    q, ref_bins, bins = io["hl_q"].double(), io["hl_bins"], h["bins"]
    if q.dim() == 3:  # decoupled [B, 3, n_bins]
        gap = (q.gather(2, ref_bins.unsqueeze(-1)) - q.gather(2, bins.unsqueeze(-1))).abs().squeeze(-1)
        differ = ref_bins != bins
    else:  # joint [B, n_bins^3], index b0 * n^2 + b1 * n + b2
        n = round(q.shape[1] ** (1.0 / 3.0))
        joint = lambda b: (b[:, 0] * n + b[:, 1]) * n + b[:, 2]
        gap = (q.gather(1, joint(ref_bins).unsqueeze(-1)) - q.gather(1, joint(bins).unsqueeze(-1))).abs().squeeze(-1)
        differ = (ref_bins != bins).any(1)
    q_ref = q.gather(-1, (ref_bins.unsqueeze(-1) if q.dim() == 3 else joint(ref_bins).unsqueeze(-1))).squeeze(-1)
    assert bool((gap[differ] <= 2 * TOL * q_ref.abs().clamp(min=1.0)[differ]).all()), "greedy bins differ beyond a tie"
    assert h["bins"].dtype == torch.int64 and h["bins"].shape == (io["ego"].shape[0], 3)
    assert torch.equal(l["action"], l["mean"].clamp(-1.0, 1.0))
    assert worst <= TOL, f"max scaled diff {worst}"
    # Any batch size, including a single aircraft.
    one = [io[k][:1] for k in ["ego", "goal", "ado", "ado_alive", "task"]]
    with torch.no_grad():
        assert scaled_diff(ll(*one)["mean"], io["ll_mean"][:1]) <= TOL
    # Wrong input shapes are refused with a message naming the input.
    try:
        ll(io["ego"][:, :3], io["goal"], io["ado"], io["ado_alive"], io["task"])
    except Exception as e:  # torch.jit.Error
        assert "ego must be" in str(e), str(e)
    else:
        raise AssertionError("bad ego shape accepted")
    print(f"torch {torch.__version__}: {folder} OK, max scaled diff {worst:.3g}")


if __name__ == "__main__":
    main(sys.argv[1])
