"""The viewpoint network: a Monte Carlo point-cloud encoder and one head per measure.

A compact, CPU-friendly take on the paper's MCCNN network (Schelling et al.
2021, section 4.3; Hermosilla et al. 2018), in plain PyTorch.

The network is assembled here from its parts, one concept per module:
:mod:`~vptoolkit.learn.config` (the architecture as data),
:mod:`~vptoolkit.learn.frame` (the canonical input frame),
:mod:`~vptoolkit.learn.hierarchy` (grid levels and neighbourhoods, no
weights), :mod:`~vptoolkit.learn.layers` (convolutions, encoder, heads) and
:mod:`~vptoolkit.learn.checkpoint` (files); import their names from them.

Preprocessing (inside the network)
    Points are put in their canonical principal-axis frame (for
    ``input_frame="pca"``), centred on their bounding-box centre and scaled to
    a unit bounding-box diagonal
    (:func:`~vptoolkit.learn.hierarchy.normalize_points`). Translation and
    uniform scaling leave directions unchanged, and the frame's rotation is
    undone on the output, so predictions come back in the input's own frame.

Encoder (:class:`PointEncoder`), default :class:`ModelConfig`

    =====  ===========================  =============================  ========  ==========
    level  points                       neighbourhood (max points)     channels  parameters
    =====  ===========================  =============================  ========  ==========
    0      the input (4096)             --                             3 (xyz)   --
    1      cell barycentres, side 1/16  own cell, offsets / 1/16 (32)  64        3,472
    2      cell barycentres, side 1/8   ball of radius 1/8 (32)        128       131,536
    3      cell barycentres, side 1/4   ball of radius 1/4 (32)        256       524,880
    4      the bounding-box centre      all of level 3, radius 1/2     512       1,049,288
    =====  ===========================  =============================  ========  ==========

    Lengths are in units of the bounding-box diagonal; a 4096-point sample
    of a typical model gives about 250-800, 70-150 and 15-60 points on
    levels 1 to 3. Each level is one :class:`MonteCarloConv` (kernel MLP
    3-16-16, 3-16-8 on level 4) followed by batch norm and ReLU; the
    encoder has 1,711,096 parameters. Level 1 integrates over grid cells rather than balls because
    a ball query on the 4096 input points costs about ten times the rest of
    the hierarchy; its overlap comes back on level 2, whose balls span two
    level-1 cells. The paper's network has four levels too, with conv radii
    0.05, 0.2, 0.3 and sqrt(3) and 128, 256, 1024 and 2048 channels.

Heads, one per measure of ``ModelConfig.measures`` (the paper's four by default), on the 512-vector
    - ``"direction"`` (SL, ML, GL, ML+GL): MLP 512-256-64-3 with batch norm,
      ReLU and dropout 0.5 after each hidden layer (148,611 parameters),
      normalised to unit length (the paper: 2048-1024-256-3).
    - ``"sr"`` (spherical regression): two such MLPs, one giving absolute
      values through the spherical exponential, one 8 sign-category logits.
    - ``"dldl"`` (distribution learning): a 2D decoder to a 32 x 32 octahedral
      sphere map (the paper's appendix: 4 x 4 deconvolution, two residual
      blocks, 4 x 4 stride-4 deconvolution, two residual blocks, 2 x 2
      stride-2 deconvolution) with 64 and 16 channels instead of 1024 and 256.

Parameter counts of the default configuration, four heads (checked by the tests)

    ==========  ==========
    head        parameters
    ==========  ==========
    direction   2,305,540
    sr          2,901,284
    dldl        4,503,932
    ==========  ==========

Checkpoints
    :func:`save_model` writes the weights as ``safetensors`` and the
    configuration as JSON beside them; :func:`load_model` reads both back and
    never unpickles anything.
"""

from __future__ import annotations

import contextlib
import math
import os
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vptoolkit.errors import CheckpointError, InputError
from vptoolkit.files import write_json_atomic
from vptoolkit.learn.checkpoint import (
    MODEL_FORMAT,
    checkpoint_paths,
    is_bundled_model,
    read_json,
    read_safetensors,
    write_safetensors_atomic,
)
from vptoolkit.learn.config import (
    MAX_PARAMETERS,
    ModelConfig,
    check_input_sizes,
    check_measure_names,
    check_positive_int,
)
from vptoolkit.learn.frame import canonical_frame, from_frame, to_frame
from vptoolkit.learn.hierarchy import check_clouds
from vptoolkit.learn.labels import (
    decode_sphere_maps,
    decode_spherical_regression,
    spherical_exponential,
)
from vptoolkit.learn.layers import DirectionHead, GeneratorDropout, PointEncoder, SphereMapDecoder
from vptoolkit.optional import require
from vptoolkit.point_features import check_feature_names, turn_features
from vptoolkit.points import N_FPS_POINTS, N_NETWORK_POINTS

if TYPE_CHECKING:
    import torch
    from torch import Tensor, nn
else:
    torch = require("torch", extra="learn")
    nn = torch.nn
    Tensor = torch.Tensor

__all__ = [
    "ViewpointNet",
    "count_parameters",
    "torch_threads",
    "resolve_device",
    "save_model",
    "load_model",
]


class ViewpointNet(nn.Module):
    """The viewpoint network: :class:`PointEncoder` and one head per measure.

    Head ``m`` predicts measure ``config.measures[m]`` (:attr:`measures`).
    Parameters are initialised from a :class:`torch.Generator` seeded with
    ``seed`` (uniform in ``+-1/sqrt(fan_in)``, PyTorch's default bounds; batch
    norm at identity), never from the global random state.

    Args:
        config (ModelConfig, optional): The architecture. (default: ``ModelConfig()``)
        seed (int): Seed of the initial weights. (default: 0)

    Shapes:
        - **input:** points :math:`(B, N, 3 + F)`, coordinates at any position
          and scale, then the :math:`F` feature columns of ``config.point_features``
          (:mod:`vptoolkit.point_features`; vectors turn with the canonical
          frame); :math:`B \\ge 2` in training
          mode (batch norm)
        - **output:** a dict with

          - ``"directions"``: :math:`(B, M, 3)` unit predictions, in the
            input's frame, one per measure of :attr:`measures` (always)
          - ``"abs_directions"``: :math:`(B, M, 3)` and ``"sign_logits"``:
            :math:`(B, M, 8)` (``head="sr"``)
          - ``"maps"``: :math:`(B, M, 32, 32)` predicted quality maps (``head="dldl"``)
          - ``"frame"``: :math:`(B, 3, 3)` the canonical frame ``C`` of each
            input (``input_frame="pca"``); ``abs_directions``, ``sign_logits``
            and ``maps`` are in that frame, ``directions`` are mapped back
            with ``d C``
    """

    def __init__(self, config: ModelConfig | None = None, *, seed: int = 0) -> None:
        super().__init__()
        config = ModelConfig() if config is None else config
        if not isinstance(config, ModelConfig):
            raise InputError(f"config: expected a ModelConfig, got {type(config).__name__}")
        self.config = config
        with torch.device("meta"):
            self.encoder = PointEncoder(config)
            latent = config.latent_channels
            width = config.head_channels
            if config.head == "direction":
                self.heads = nn.ModuleList(
                    DirectionHead(latent, width, 3, config.dropout)
                    for _ in range(config.n_measures))
            elif config.head == "sr":
                self.heads = nn.ModuleList(
                    DirectionHead(latent, width, 3, config.dropout)
                    for _ in range(config.n_measures))
                self.sign_heads = nn.ModuleList(
                    DirectionHead(latent, width, 8, config.dropout)
                    for _ in range(config.n_measures))
            else:
                self.heads = nn.ModuleList(
                    SphereMapDecoder(latent, config.decoder_channels)
                    for _ in range(config.n_measures))
        n_parameters = count_parameters(self)  # counted on the meta device, before any allocation
        if n_parameters > MAX_PARAMETERS:
            raise InputError(f"architecture: {n_parameters:,} parameters exceed the "
                             f"{MAX_PARAMETERS:,} a network may have")
        self.to_empty(device="cpu")
        self.reset_parameters(seed=seed)
        self._generator: torch.Generator | None = None

    @property
    def measures(self) -> tuple[str, ...]:
        """The measure of each head, in the order of the outputs' axis ``M``."""
        return self.config.measures

    def reset_parameters(self, *, seed: int = 0) -> None:
        """Initialise every weight from a generator seeded with ``seed``.

        Linear and convolution weights and biases are uniform in
        ``+-1/sqrt(fan_in)``; batch norm has weight 1, bias 0 and fresh
        running statistics.
        """
        generator = torch.Generator().manual_seed(int(seed))
        with torch.no_grad():
            for module in self.modules():
                if isinstance(module, (nn.Linear, nn.Conv2d, nn.ConvTranspose2d)):
                    bound = 1.0 / math.sqrt(module.weight[0].numel())
                    module.weight.uniform_(-bound, bound, generator=generator)
                    if module.bias is not None:
                        module.bias.uniform_(-bound, bound, generator=generator)
                elif isinstance(module, (nn.BatchNorm1d, nn.BatchNorm2d)):
                    module.reset_parameters()

    def set_generator(self, generator: torch.Generator | None) -> None:
        """Draw dropout masks and, in training, ambiguous frame signs from ``generator``."""
        self._generator = generator
        for module in self.modules():
            if isinstance(module, GeneratorDropout):
                module.generator = generator

    def forward(self, points: Tensor) -> dict[str, Tensor]:
        frame = None
        if self.config.input_frame == "pca":
            check_clouds(points, self.config.input_channels)
            coordinates, features = points[..., :3], points[..., 3:]
            frame, centre = canonical_frame(
                coordinates, generator=self._generator if self.training else None)
            features = turn_features(features, self.config.point_features, frame.transpose(1, 2))
            points = torch.cat([to_frame(coordinates, frame, centre), features], dim=-1)
        outputs = self._heads(self.encoder(points))
        if frame is not None:
            outputs["directions"] = from_frame(outputs["directions"], frame)
            outputs["frame"] = frame
        return outputs

    def forward_in_frames(self, points: Tensor, frames: Tensor,
                          centre: Tensor) -> dict[str, Tensor]:
        """The heads' outputs for one cloud ``(N, 3 + F)`` put in each of ``frames`` ``(K, 3, 3)``.

        The network sees ``(x - centre) C_f^T`` for every frame ``C_f`` (the
        point features, if any, with their vectors turned alike, ``v C_f^T``);
        ``"directions"`` ``(K, M, 3)`` come back in the input's frame (``d C_f``),
        every other output (``"maps"`` of a DLDL head) stays in its frame:
        :meth:`forward` is the case of the one canonical frame. For the frames of
        ambiguous axis signs (:class:`vptoolkit.learn.prior.NetworkPrior`).
        """
        clouds = points[None].expand(len(frames), -1, -1)
        features = turn_features(clouds[..., 3:], self.config.point_features,
                                 frames.transpose(1, 2))
        inputs = torch.cat([to_frame(clouds[..., :3], frames, centre), features], dim=-1)
        outputs = self._heads(self.encoder(inputs))
        outputs["directions"] = from_frame(outputs["directions"], frames)
        return outputs

    def _heads(self, latent: Tensor) -> dict[str, Tensor]:
        """Head outputs in the frame the encoder saw."""
        head = self.config.head
        if head == "direction":
            raw = torch.stack([mlp(latent) for mlp in self.heads], dim=1)
            return {"directions": raw / raw.norm(dim=-1, keepdim=True).clamp_min(1e-12)}
        if head == "sr":
            abs_directions = spherical_exponential(
                torch.stack([mlp(latent) for mlp in self.heads], dim=1))
            sign_logits = torch.stack([mlp(latent) for mlp in self.sign_heads], dim=1)
            return {
                "directions": decode_spherical_regression(abs_directions.detach(),
                                                          sign_logits.detach()),
                "abs_directions": abs_directions,
                "sign_logits": sign_logits,
            }
        maps = torch.stack([decoder(latent) for decoder in self.heads], dim=1)
        return {"directions": decode_sphere_maps(maps.detach()), "maps": maps}


def count_parameters(model: nn.Module) -> int:
    """Number of learned parameters (batch-norm running statistics excluded)."""
    return sum(parameter.numel() for parameter in model.parameters())


@contextlib.contextmanager
def torch_threads(threads: int | None) -> Iterator[None]:
    """Set torch's intra-op thread count for a block and restore it afterwards.

    Parameters
    ----------
    threads : int or None
        Threads to use, at least 1; None leaves torch's setting alone.

    Raises
    ------
    InputError
        If ``threads`` is not a positive integer or None.
    """
    if threads is None:
        yield
        return
    check_positive_int(threads, "threads")
    previous = torch.get_num_threads()
    torch.set_num_threads(threads)
    try:
        yield
    finally:
        torch.set_num_threads(previous)


def resolve_device(device: str) -> torch.device:
    """``"auto"`` (CUDA when available, else the CPU), ``"cpu"`` or ``"cuda"`` / ``"cuda:N"``.

    Raises
    ------
    InputError
        For another name, or CUDA asked for where torch sees no CUDA device.
    """
    if device == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    if device == "cpu":
        return torch.device("cpu")
    if isinstance(device, str) and (device == "cuda" or device.startswith("cuda:")):
        if not torch.cuda.is_available():
            raise InputError(f"device: {device!r} asked for, but torch {torch.__version__} "
                             "sees no CUDA device")
        return torch.device(device)
    raise InputError(f"device: expected 'auto', 'cpu' or 'cuda', got {device!r}")


def save_model(model: ViewpointNet, path: str | os.PathLike[str], *,
               metadata: Mapping[str, Any] | None = None, half: bool = False) -> tuple[Path, Path]:
    """Save a network as ``safetensors`` weights plus a JSON configuration.

    Parameters
    ----------
    model : ViewpointNet
        The network; its ``state_dict`` (weights and batch-norm statistics)
        is saved.
    path : path-like
        Folder or ``*.safetensors`` file (:func:`checkpoint_paths`); the
        folder is created.
    metadata : mapping, optional
        More JSON entries for the configuration (label method, training
        arguments, scores, ...). ``format``, ``architecture``, ``measures``
        (the heads' measure names, as in the architecture), ``n_parameters``
        and ``weights_dtype`` are always written by this function.
    half : bool
        Store floating-point tensors as float16 (half the file size; they
        are loaded back into the float32 network). Default: False.

    Returns
    -------
    weights, config : Path
    """
    if not isinstance(model, ViewpointNet):
        raise InputError(f"model: expected a ViewpointNet, got {type(model).__name__}")
    weights_path, config_path = checkpoint_paths(path)
    weights_path.parent.mkdir(parents=True, exist_ok=True)
    config = dict(metadata or {})
    config.update({
        "format": MODEL_FORMAT,
        "format_version": 1,
        "architecture": model.config.to_dict(),
        "measures": list(model.measures),
        "n_parameters": count_parameters(model),
        "weights_dtype": "float16" if half else "float32",
    })
    state = model.state_dict()
    if half:
        state = {name: tensor.half() if tensor.is_floating_point() else tensor
                 for name, tensor in state.items()}
    write_safetensors_atomic(weights_path, state, {"format": MODEL_FORMAT})
    write_json_atomic(config_path, config)
    return weights_path, config_path


def _check_trained_features(config: Mapping[str, Any], architecture: ModelConfig) -> None:
    """Refuse point features other than, or in another order than, the training's record.

    The weights cannot tell ``[face_area, normal]`` from ``[normal, face_area]``
    (the same widths), so the network would read each channel as the other;
    ``training.arguments.architecture.point_features``, where a trained
    checkpoint records it, is the order the weights learnt.
    """
    training = config.get("training")
    arguments = training.get("arguments") if isinstance(training, Mapping) else None
    trained = arguments.get("architecture") if isinstance(arguments, Mapping) else None
    if not isinstance(trained, Mapping) or "point_features" not in trained:
        return
    recorded = check_feature_names(trained["point_features"])
    if recorded != architecture.point_features:
        raise InputError(
            f"architecture.point_features {list(architecture.point_features)} are not the "
            f"{list(recorded)} the network was trained with "
            "(training.arguments.architecture.point_features)")


def load_model(path: str | os.PathLike[str]) -> tuple[ViewpointNet, dict[str, Any]]:
    """Load a network saved by :func:`save_model` (or by training), in eval mode.

    Parameters
    ----------
    path : path-like
        Folder, ``*.safetensors`` or ``*.json`` of the checkpoint.

    Returns
    -------
    model : ViewpointNet
        In evaluation mode.
    config : dict
        The JSON configuration (architecture, label method, measures,
        training arguments, best score, toolkit version, ...).

    Raises
    ------
    InputError
        If ``path`` does not exist (naming it), a file is missing or
        unreadable, the configuration is not a
        vptoolkit model, has no ``architecture``, names a measure the
        registry does not know (:func:`vptoolkit.measures.registry.resolve_measures`)
        or other measures than its architecture's heads, or asks for sizes
        beyond the bounds of :mod:`vptoolkit.learn.config`, or a weight is
        NaN or infinite.
    CheckpointError
        If the weights do not match the architecture.
    """
    if not is_bundled_model(path) and not Path(path).exists():
        raise InputError(f"{path}: no such checkpoint (a folder, *.safetensors or *.json file, "
                         "or a bundled name: 'default', 'points')")
    weights_path, config_path = checkpoint_paths(path)
    config = read_json(config_path, "model configuration")
    if config.get("format") != MODEL_FORMAT:
        raise InputError(f"{config_path.name}: not a vptoolkit model configuration "
                         f"(format {config.get('format')!r})")
    if config.get("format_version", 1) != 1:
        raise InputError(f"{config_path.name}: format_version "
                         f"{config.get('format_version')!r} is not 1, "
                         "the only one this vptoolkit reads")
    try:
        trained = config.get("input", {})
        if not isinstance(trained, Mapping):
            raise InputError(f"input: expected an object, got {type(trained).__name__}")
        check_input_sizes(trained.get("n_points", N_NETWORK_POINTS),
                          trained.get("n_fps", N_FPS_POINTS),
                          prefix="input.")
        if "architecture" not in config:
            raise InputError("architecture: missing; a checkpoint names its network's architecture")
        described = config["architecture"]
        if not isinstance(described, Mapping):
            raise InputError(f"architecture: expected an object, got {type(described).__name__}")
        architecture = ModelConfig.from_dict(described)
        # The top-level names, where given, must be the heads' (the architecture's order).
        named = check_measure_names(config.get("measures", list(architecture.measures)))
        if named != architecture.measures:
            raise InputError(f"measures: the measure order {', '.join(named)} is not that of "
                             f"the architecture's heads ({', '.join(architecture.measures)})")
        _check_trained_features(config, architecture)
        model = ViewpointNet(architecture)
    except InputError as err:
        raise InputError(f"{config_path.name}: {err}") from err
    state = read_safetensors(weights_path)  # float16 weights are cast on loading
    broken = next((name for name, tensor in state.items()
                   if tensor.is_floating_point() and not bool(torch.isfinite(tensor).all())), None)
    if broken is not None:
        raise InputError(f"{weights_path.name}: weight {broken} holds NaN or infinite values")
    try:
        model.load_state_dict(state, strict=True)
    except RuntimeError as err:
        raise CheckpointError(f"{weights_path.name}: weights do not match the architecture "
                              f"({err})") from err
    model.eval()
    return model, config
