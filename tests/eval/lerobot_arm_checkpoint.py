"""Write an untrained ACT checkpoint for a single WidowX AI arm (run by the LeRobot venv's
Python, ``tests/eval/test_lerobot_arm.py``): 7 state values, one camera, 7 actions, saved with
its processors. ``--hold v0,..,v6``: its action unnormalizer's mean is those values and its
std 1e-6, so every action is those 7 values (a policy that holds the arm still).

    python lerobot_arm_checkpoint.py OUT --image_size 24x32 [--camera cam] [--hold ...]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import torch
from lerobot.configs.types import FeatureType, PolicyFeature
from lerobot.policies.act.configuration_act import ACTConfig
from lerobot.policies.act.modeling_act import ACTPolicy
from lerobot.policies.factory import make_pre_post_processors


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("out")
    p.add_argument("--image_size", default="24x32")
    p.add_argument("--camera", default="cam")
    p.add_argument("--hold", default=None)
    args = p.parse_args()
    h, w = (int(v) for v in args.image_size.split("x"))
    image = f"observation.images.{args.camera}"
    cfg = ACTConfig(
        input_features={
            "observation.state": PolicyFeature(FeatureType.STATE, (7,)),
            image: PolicyFeature(FeatureType.VISUAL, (3, h, w)),
        },
        output_features={"action": PolicyFeature(FeatureType.ACTION, (7,))},
        device="cpu",
        pretrained_backbone_weights=None,
        use_vae=False,
        chunk_size=10,
        n_action_steps=10,
        dim_model=32,
        dim_feedforward=64,
        n_encoder_layers=1,
        n_decoder_layers=1,
        push_to_hub=False,
    )
    torch.manual_seed(0)
    policy = ACTPolicy(cfg)
    action_mean, action_std = torch.zeros(7), torch.ones(7)
    if args.hold:
        action_mean = torch.tensor([float(v) for v in args.hold.split(",")])
        action_std = torch.full((7,), 1e-6)
    stats = {
        "observation.state": {"mean": torch.zeros(7), "std": torch.ones(7)},
        "action": {"mean": action_mean, "std": action_std},
        image: {"mean": torch.zeros(3, 1, 1), "std": torch.ones(3, 1, 1)},
    }
    pre, post = make_pre_post_processors(cfg, dataset_stats=stats)
    out = Path(args.out)
    policy.save_pretrained(out)
    pre.save_pretrained(out)
    post.save_pretrained(out)


if __name__ == "__main__":
    main()
