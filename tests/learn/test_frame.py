"""The canonical input frame: principal axes signed by third moments; the network's equivariance."""

from __future__ import annotations

import numpy as np
import pytest

from fixtures.environment import require_package

require_package("torch")

import torch  # noqa: E402

from vptoolkit.errors import InputError  # noqa: E402
from vptoolkit.io import load_mesh  # noqa: E402
from vptoolkit.learn import model as M  # noqa: E402
from vptoolkit.learn.config import HEADS, ModelConfig  # noqa: E402
from vptoolkit.learn.frame import canonical_frame, from_frame, to_frame  # noqa: E402
from vptoolkit.learn.labels import label_loss  # noqa: E402
from vptoolkit.points import network_input, sample_surface  # noqa: E402
from vptoolkit.rotations import fixed_rotations  # noqa: E402
from vptoolkit.samples import sample_path  # noqa: E402

pytestmark = pytest.mark.usefixtures("one_thread")
MESHES = ("bunny", "mug", "Duck", "table")


@pytest.fixture(scope="module")
def clouds(one_thread: None) -> dict[str, np.ndarray]:
    """2048-point network inputs of real sample meshes, in their own coordinates."""
    result = {}
    for name in MESHES:
        surface = sample_surface(load_mesh(sample_path(name)), 6000, seed=0).points
        result[name] = network_input(surface, 2048, 512, rng=np.random.default_rng(0))
    return result


def angles(first: np.ndarray, second: np.ndarray) -> np.ndarray:
    unit = lambda v: v / np.linalg.norm(v, axis=-1, keepdims=True)  # noqa: E731
    return np.degrees(np.arccos(np.clip((unit(first) * unit(second)).sum(-1), -1.0, 1.0)))


def test_frame_is_orthogonal_sorted_by_variance_and_skewed_positive(clouds):
    points = torch.tensor(np.stack(list(clouds.values())))
    frame, centre = canonical_frame(points)
    assert torch.allclose(frame @ frame.transpose(1, 2),
                          torch.eye(3, dtype=frame.dtype).expand_as(frame), atol=1e-10)
    canonical = to_frame(points, frame, centre)
    assert torch.allclose(canonical.mean(dim=1), torch.zeros(len(clouds), 3, dtype=frame.dtype),
                          atol=1e-10)
    variance = canonical.pow(2).mean(dim=1)
    assert bool((variance[:, :-1] >= variance[:, 1:]).all())
    assert bool((canonical.pow(3).mean(dim=1) >= 0).all())
    # the frame diagonalises the covariance
    covariance = canonical.transpose(1, 2) @ canonical / canonical.shape[1]
    off_diagonal = covariance - torch.diag_embed(torch.diagonal(covariance, dim1=1, dim2=2))
    assert float(off_diagonal.abs().max()) < 1e-10


def test_frame_turns_with_the_input(clouds):
    for name, cloud in clouds.items():
        frame, _ = canonical_frame(torch.tensor(cloud[None]))
        for rotation in fixed_rotations(name, 4):
            turned, _ = canonical_frame(torch.tensor((cloud @ rotation.T)[None]))
            # C(x R^T) = C(x) R^T: the canonical cloud is the same point set
            assert np.allclose(turned[0].numpy(), frame[0].numpy() @ rotation.T, atol=1e-8), name


def test_directions_go_back_with_the_frame(clouds):
    frame, _ = canonical_frame(torch.tensor(clouds["bunny"][None]))
    direction = torch.tensor([[[0.2, -0.5, 0.8]]], dtype=frame.dtype)
    canonical = direction @ frame.transpose(1, 2)
    assert torch.allclose(from_frame(canonical, frame), direction)


def test_ambiguous_signs_are_drawn_in_training_and_fixed_in_evaluation():
    # A box of points symmetric about all three axes: every third moment is about 0.
    rng = np.random.default_rng(0)
    box = rng.uniform(-1, 1, size=(4000, 3)) * np.array([3.0, 2.0, 1.0])
    box = torch.tensor(np.concatenate([box, -box])[None])
    fixed = [canonical_frame(box)[0] for _ in range(2)]
    assert torch.equal(fixed[0], fixed[1])
    drawn = {tuple(np.sign(np.diagonal(
                 canonical_frame(box, generator=torch.Generator().manual_seed(seed))[0][0].numpy()
             )).astype(int)) for seed in range(12)}
    assert len(drawn) > 2  # several sign patterns over the ambiguous axes
    # a clearly skewed cloud keeps its signs whatever the generator
    skewed = torch.tensor(rng.exponential(size=(1, 4000, 3)) * np.array([3.0, 2.0, 1.0]))
    frames = [canonical_frame(skewed, generator=torch.Generator().manual_seed(seed))[0]
              for seed in range(4)]
    assert all(torch.equal(frames[0], other) for other in frames[1:])


def test_coincident_points_get_the_identity_frame():
    frame, _ = canonical_frame(torch.ones(1, 10, 3))
    assert torch.equal(frame[0], torch.eye(3, dtype=frame.dtype))


@pytest.mark.parametrize("head", HEADS)
def test_rotating_the_input_rotates_the_prediction(head, clouds):
    """Median angle over seeded rotations below 10 degrees (the issue's tolerance).

    In exact arithmetic the prediction turns with the input unless an axis's
    third moment changes sign; the slack covers that for near-symmetric
    shapes and float32 rounding. Without the frame the same untrained network
    lands about 90 degrees off, i.e. at random.
    """
    network = M.ViewpointNet(ModelConfig(head=head), seed=0).eval()
    plain = M.ViewpointNet(ModelConfig(head=head, input_frame="none"), seed=0).eval()
    errors, plain_errors = [], []
    with torch.no_grad():
        for name, cloud in clouds.items():
            for net, sink in ((network, errors), (plain, plain_errors)):
                reference = net(
                    torch.tensor(cloud[None], dtype=torch.float32))["directions"][0].numpy()
                for rotation in fixed_rotations(name, 3, seed=1):
                    turned = torch.tensor((cloud @ rotation.T)[None], dtype=torch.float32)
                    back = net(turned)["directions"][0].numpy() @ rotation
                    sink.extend(angles(back, reference))
    assert np.median(errors) < 10.0, np.round(errors, 1)
    assert np.median(plain_errors) > 30.0


@pytest.mark.parametrize("head,phase", [("direction", "sl"), ("direction", "gl"), ("sr", "sr"),
                                        ("dldl", "dldl")])
def test_losses_do_not_depend_on_the_orientation(head, phase, clouds):
    """Labels rotate with the input; canonical-frame heads get theirs mapped into that frame."""
    network = M.ViewpointNet(ModelConfig(head=head), seed=0).eval()
    cloud = clouds["bunny"]
    rng = np.random.default_rng(3)
    views = rng.standard_normal((200, 3))
    views /= np.linalg.norm(views, axis=1, keepdims=True)
    quality = rng.uniform(size=(200, 4))
    quality[rng.integers(200, size=4), np.arange(4)] = 1.0
    losses = []
    with torch.no_grad():
        for rotation in [np.eye(3), *fixed_rotations("bunny", 2)]:
            turned_views = views @ rotation.T
            batch = {
                "views": torch.tensor(turned_views[None], dtype=torch.float32),
                "quality": torch.tensor(quality[None], dtype=torch.float32),
                "best_views": torch.tensor(turned_views[quality.argmax(axis=0)][None],
                                           dtype=torch.float32),
            }
            outputs = network(torch.tensor((cloud @ rotation.T)[None], dtype=torch.float32))
            losses.append(label_loss(phase, outputs, batch).numpy())
    assert np.allclose(losses[0], losses[1], atol=2e-3), losses
    assert np.allclose(losses[0], losses[2], atol=2e-3), losses


def test_the_input_frame_is_recorded_and_checked(tmp_path):
    values = ModelConfig().to_dict()
    assert values["input_frame"] == "pca"
    del values["input_frame"]
    # a partial architecture gets the default, as for every other key
    assert ModelConfig.from_dict(values).input_frame == "pca"
    M.save_model(M.ViewpointNet(ModelConfig(input_frame="none")), tmp_path / "raw")
    assert M.load_model(tmp_path / "raw")[0].config.input_frame == "none"
    with pytest.raises(InputError, match="input_frame"):
        ModelConfig(input_frame="octant")


def face_areas(name: str) -> np.ndarray:
    """The face_area feature of the points of ``clouds[name]``, in their order."""
    from vptoolkit.point_features import face_area_feature
    from vptoolkit.points import network_input_indices

    mesh = load_mesh(sample_path(name))
    sample = sample_surface(mesh, 6000, seed=0)
    chosen = network_input_indices(sample.points, 2048, 512, rng=np.random.default_rng(0))
    return face_area_feature(mesh, sample.face_index[chosen])[:, None]


@pytest.mark.parametrize("bundled", ["default", "points"])
def test_the_shipped_networks_turn_with_their_input(clouds, bundled):
    network, _ = M.load_model(bundled)
    assert network.config.input_frame == "pca"
    errors = []
    with torch.no_grad():
        for name, cloud in clouds.items():
            features = face_areas(name) if network.config.point_features else cloud[:, :0]

            def ask(points: np.ndarray) -> np.ndarray:
                inputs = torch.tensor(np.hstack([points, features])[None], dtype=torch.float32)
                return network(inputs)["directions"][0].numpy()

            reference = ask(cloud)
            for rotation in fixed_rotations(name, 3, seed=2):
                errors.extend(angles(ask(cloud @ rotation.T) @ rotation, reference))
    assert np.median(errors) < 10.0, np.round(errors, 1)


@pytest.mark.parametrize("scale", [1e-37, 1e-15, 1e20, 1e37])
def test_the_frame_does_not_depend_on_the_size_of_the_cloud(clouds, scale):
    cloud = torch.tensor(clouds["bunny"][None], dtype=torch.float64)
    reference, _ = canonical_frame(cloud)
    frame, _ = canonical_frame(cloud * scale)
    torch.testing.assert_close(frame, reference, rtol=0, atol=1e-9)


@pytest.mark.parametrize("bundled", ["default", "points"])
def test_the_shipped_networks_answer_alike_at_any_size(clouds, bundled):
    from vptoolkit.learn.predict import MeshPredictor

    network, _ = M.load_model(bundled)
    cloud = clouds["bunny"]
    features = face_areas("bunny") if network.config.point_features else cloud[:, :0]

    def ask(scale: float) -> np.ndarray:  # float32, as a point file holds it
        inputs = torch.tensor(np.hstack([cloud * scale, features])[None], dtype=torch.float32)
        with torch.no_grad():
            return network(inputs)["directions"][0].numpy()

    reference = ask(1.0)
    for scale in (1e-30, 1e-14, 1e20, 1e30):
        assert angles(ask(scale), reference).max() < 0.1, scale
    if bundled == "default":  # meshes: normalised in float64 before the float32 input
        mesh = load_mesh(sample_path("bunny"))
        predictor = MeshPredictor(bundled, n_inputs=2)
        answer = predictor(mesh)
        for scale in (1e-36, 1e-15, 1e20, 1e36):
            scaled = mesh.__class__(mesh.vertices * scale, mesh.faces, name=mesh.name)
            assert angles(predictor(scaled), answer).max() < 0.1, scale
