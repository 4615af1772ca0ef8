"""Export a stable-baselines3 PPO model's deterministic policy as the arrays `shieldnav.policies`
evaluates with numpy (``w0, b0, …``: the policy network's linear layers, then the action head).

    python -m agents.export_policy runs/ppo/model.zip envs/shieldnav/policies/ppo_corridor.npz

Only what `shieldnav.policies.MlpPolicy` computes is accepted: an ``MlpPolicy`` with tanh hidden
layers, a Gaussian action head and no feature extractor beyond flattening.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from shieldnav.exceptions import InvalidArgumentError


def export(model_path: Path | str, out: Path | str) -> Path:
    """Writes the arrays of ``model_path``'s policy to ``out`` (``.npz``); returns ``out``."""
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.distributions import DiagGaussianDistribution
    from stable_baselines3.common.torch_layers import FlattenExtractor

    if not Path(model_path).exists():
        raise InvalidArgumentError(f"invalid `model`: {model_path} does not exist")
    policy = PPO.load(model_path, device="cpu").policy
    hidden = list(policy.mlp_extractor.policy_net)
    linears = [m for m in hidden if isinstance(m, torch.nn.Linear)]
    activations = [m for m in hidden if not isinstance(m, torch.nn.Linear)]
    if not isinstance(policy.action_dist, DiagGaussianDistribution) or not isinstance(policy.pi_features_extractor, FlattenExtractor) \
            or len(activations) != len(linears) or not all(isinstance(m, torch.nn.Tanh) for m in activations):
        raise InvalidArgumentError(f"invalid `model`: {model_path} is not an MlpPolicy with tanh layers and a Gaussian head")
    arrays = {}
    for k, layer in enumerate([*linears, policy.action_net]):
        arrays[f"w{k}"] = layer.weight.detach().numpy().astype(np.float32)
        arrays[f"b{k}"] = layer.bias.detach().numpy().astype(np.float32)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(out, **arrays)
    return out


def main(argv: list[str] | None = None) -> Path:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("model", help="a saved SB3 PPO model (.zip)")
    ap.add_argument("out", help="the .npz to write")
    args = ap.parse_args(argv)
    path = export(args.model, args.out)
    print(f"wrote {path}")
    return path


if __name__ == "__main__":
    main()
