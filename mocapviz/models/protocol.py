"""The model protocol: what the trainer, checkpoints, zoo and generator ask of a model.

A model is an ``nn.Module`` class registered under the name stored in checkpoint metadata::

    @register_model("ccnet")
    class CCNet(nn.Module):
        config_class = CCNetConfig              # frozen dataclass with to_json() / from_json()
        input_names = ("x", "skel", "traj", "types")   # batch keys that forward() takes

        @classmethod
        def config_for(cls, train_cfg, layout) -> CCNetConfig: ...   # sizes from the data layout
        def forward(self, x, skel, traj, types) -> dict[str, Tensor]: ...  # named outputs
        def stepper(self, batch, backend) -> Stepper: ...   # incremental generation

so that ERD-4LR, DAE-LSTM, PFNN, an LSTM ablation or the 4D CVAE plug in without editing the
trainer: a new model registers here and names its loss. **The loss is looked up by the model's
name** in :data:`mocapviz.training.losses.LOSSES` (models sit below training in the layers and
do not import it; one model name, one loss). The steppers live in :mod:`mocapviz.models.steppers`.
"""

from __future__ import annotations

from typing import Any, ClassVar, Protocol

from torch import nn

MODELS: dict[str, type] = {}


class Stepper(Protocol):
    """Incremental generation: one frame per call, the past kept inside."""

    def reset(self) -> None: ...

    def set_static(self, *conditions) -> None:
        """Conditions that stay fixed over many frames (e.g. skeleton and motion type)."""

    def step(self, x, control):
        """Frame t and its per-frame control -> the raw network output for frame t+1."""


class ModelConfig(Protocol):
    def to_json(self) -> str: ...

    @classmethod
    def from_json(cls, s: str) -> "ModelConfig": ...


class MotionModel(Protocol):
    name: ClassVar[str]
    config_class: ClassVar[type]
    input_names: ClassVar[tuple[str, ...]]
    cfg: Any

    @classmethod
    def config_for(cls, train_cfg, layout) -> ModelConfig: ...

    def forward(self, **inputs) -> dict: ...

    def stepper(self, batch: int, backend: str) -> Stepper: ...


def register_model(name: str):
    """Class decorator: record the model class under ``name`` (and set its ``name``)."""
    def deco(cls):
        if name in MODELS and MODELS[name] is not cls:
            raise ValueError(f"model {name!r} registered twice")
        cls.name = name
        MODELS[name] = cls
        return cls
    return deco


def model_class(name: str) -> type:
    """The registered class of ``name`` (importing the built-in models first)."""
    import mocapviz.models.ccnet  # noqa: F401 - registers "ccnet"
    import mocapviz.models.dae_lstm  # noqa: F401 - registers "dae_lstm"
    import mocapviz.models.erd  # noqa: F401 - registers "erd"
    import mocapviz.models.pfnn  # noqa: F401 - registers "pfnn"
    import mocapviz.models.cvae4d  # noqa: F401 - registers "cvae4d"
    try:
        return MODELS[name]
    except KeyError:
        raise KeyError(f"unknown model {name!r}; registered: {sorted(MODELS)}") from None


def build_model(name: str, config_json: str) -> nn.Module:
    """A fresh model of the registered class ``name`` from its config's JSON (checkpoints)."""
    cls = model_class(name)
    return cls(cls.config_class.from_json(config_json))


def count_parameters(model: nn.Module) -> int:
    return sum(p.numel() for p in model.parameters())
