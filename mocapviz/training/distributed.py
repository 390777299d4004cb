"""DistributedDataParallel under ``torchrun``: rank and world size from the environment."""

from __future__ import annotations

import os

import torch.distributed as dist


def rank_and_world() -> tuple[int, int]:
    """(rank, world size); joins the gloo process group when ``WORLD_SIZE`` > 1 (torchrun)."""
    world = int(os.environ.get("WORLD_SIZE", "1"))
    if world > 1 and not dist.is_initialized():
        dist.init_process_group("gloo")
    return (dist.get_rank(), world) if world > 1 else (0, 1)


def rank_from_env() -> int:
    """This process's rank before the process group exists (0 outside torchrun)."""
    return int(os.environ.get("RANK", "0"))


def finish() -> None:
    """Leave the process group, if one was joined."""
    if dist.is_initialized():
        dist.destroy_process_group()
