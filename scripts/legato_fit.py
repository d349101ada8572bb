"""How well a LEGATO or BC-RNN checkpoint fits its demonstrations, open loop, and how much an
image policy's action depends on where things are in its frames.

    python scripts/legato_fit.py RUN/selected.pt DATA.hdf5 [--split valid] [--windows 100]
                                 [--shifts 4,10,20 | --moves 10,25,50 | --offsets 10,25,50]
                                 [--phases]

For ``--windows`` random windows of ``seq_length`` steps of the demos in ``--split``
(seeded), the policy reads the window's observations as it would at rollout (evaluation
mode: the centre crop, the LSTM started afresh at the window's start) and its low-noise
action at every step is compared with the recorded one. The script prints, over those steps:

* the translation error of the pose delta (median and 90th percentile, mm) beside the
  demonstration's own step (median, mm);
* the rotation error (the Euler-delta difference's norm, degrees);
* how often the grasp commands agree.

With ``--shifts`` (image checkpoints only), every frame of a window is also translated by k
pixels (one random direction per window, the border repeated) and the script prints how far
the predicted translation moves (median and 90th percentile, mm). A policy that must find a
handle in its view should answer a shift of its view; one whose action hardly changes has
learned to ignore where things are. But a shift of the whole view is also what a random-crop
augmentation shows the network in training with the same label, so a policy trained with
crops is taught to ignore exactly that. ``--moves`` asks the question without that confound:
every frame of the window is rendered again from the demo's recorded plant state with the
task's objects moved k mm in the gripper's frame (one random direction per window; the
gripper, the table and the camera stay), and the script prints how far the predicted
translation moves against the same frames rendered unmoved. ``--offsets`` (state checkpoints
reading ``object_in_tcp``) moves the objects by the same k mm in the state a state policy
reads: the two answers compare directly.

For an image checkpoint the script prints how sharply each camera's keypoints point: the
median over the frames and keypoints of a keypoint's largest softmax weight on the feature map
(1: all on one cell; one over the cells: spread evenly).

For an image checkpoint trained with the auxiliary object loss (``object_aux_weight``), the
script also prints how far the objects' positions that its head reads from the frames are
from the true ones (median and 90th percentile, mm, per object body): whether the encoder
locates what it sees.

``--phases`` breaks the translation error (and the object head's error) down by where each
step lies relative to the demo's first grasp command: far from the object, on the final
approach, just after the grasp, and the rest: where along the task the fit is worst, and
whether the encoder locates the object better as the gripper nears it.

It also prints how decided the policy's Gaussian mixture is: the weight of its most likely
component (whose mean is the low-noise action), how often that component changes from one
step to the next, and how far the action then jumps.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Iterator
from pathlib import Path

import h5py
import numpy as np
import torch

from legato_drake.data.derived import VALUES_PER_BODY
from legato_drake.data.layout import IMAGE_KEYS
from legato_drake.data.torch_dataset import SPLITS, DemoSequenceDataset, image_to_tensor
from legato_drake.learning.checkpoint import load_checkpoint
from legato_drake.learning.policies import RecurrentGMMPolicy


def shift_frames(frames: torch.Tensor, dy: int, dx: int) -> torch.Tensor:
    """Frames (..., H, W) translated by (dy, dx) pixels, the border pixels repeated."""
    H, W = frames.shape[-2:]
    rows = (torch.arange(H) - dy).clamp(0, H - 1)
    cols = (torch.arange(W) - dx).clamp(0, W - 1)
    return frames[..., rows, :][..., cols]


def offset_objects(object_in_tcp: torch.Tensor, offset: np.ndarray) -> torch.Tensor:
    """``object_in_tcp`` values (..., 9k) with every body's position moved by ``offset`` (m)."""
    n = VALUES_PER_BODY["object_in_tcp"]
    moved = object_in_tcp.clone()
    for body in range(moved.shape[-1] // n):
        moved[..., n * body:n * body + 3] += torch.as_tensor(offset, dtype=moved.dtype)
    return moved


class SceneRenderer:
    """Renders a demo's gripper frames again from its recorded plant states, with the task's
    objects optionally moved in the gripper's frame (``--moves``). One diagram per demo (its
    recorded scenario, the camera it was recorded with), built on first use."""

    def __init__(self, data: Path, image_keys: list[str]):
        self._file = h5py.File(data, "r")
        self._keys = image_keys
        self._built: dict[str, tuple] = {}

    def _diagram(self, demo: str) -> tuple:
        if demo not in self._built:
            # The robot side, imported only for this option.
            from legato_drake.diagram import build_diagram, object_bodies
            from legato_drake.scenario import scenario_from_yaml_text

            text = self._file[f"data/{demo}"].attrs["scenario"]
            built = build_diagram(scenario_from_yaml_text(text, f"{demo}'s scenario"))
            context = built.diagram.CreateDefaultContext()
            # The root context is kept: the plant's and the camera's contexts live inside it.
            self._built[demo] = (built, context,
                                 built.plant.GetMyMutableContextFromRoot(context),
                                 built.camera.GetMyContextFromRoot(context),
                                 object_bodies(built.plant, built.robot))
        return self._built[demo]

    def frames(self, demo: str, steps: np.ndarray, offset: np.ndarray
               ) -> dict[str, torch.Tensor]:
        """The frames (L, 1, H, W) of ``demo``'s samples ``steps``, rendered with every object
        moved by ``offset`` (m, in the gripper's TCP frame)."""
        from pydrake.math import RigidTransform

        built, _, plant_context, camera_context, bodies = self._diagram(demo)
        plant = built.plant
        states = self._file[f"data/{demo}/states"]
        rendered: dict[str, list[np.ndarray]] = {key: [] for key in self._keys}
        for step in steps:
            plant.SetPositionsAndVelocities(plant_context, states[int(step)])
            shift = built.robot.tcp_frame.CalcPoseInWorld(plant_context).rotation() @ offset
            for body in bodies:
                X_WB = body.EvalPoseInWorld(plant_context)
                plant.SetFreeBodyPose(plant_context, body,
                                      RigidTransform(X_WB.rotation(), X_WB.translation() + shift))
            for key, image in zip(("left_gray", "right_gray"),
                                  built.camera.render(camera_context), strict=True):
                if key in rendered:
                    rendered[key].append(image)
        return {key: image_to_tensor(np.stack(images))
                for key, images in rendered.items()}


def predict(policy: RecurrentGMMPolicy, obs: dict[str, torch.Tensor]) -> torch.Tensor:
    """The low-noise actions (T, 7) of one window's observations (T, ...)."""
    return predict_with_modes(policy, obs)[0]


def predict_with_modes(policy: RecurrentGMMPolicy, obs: dict[str, torch.Tensor]
                       ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """The low-noise actions (T, 7) of one window's observations, the weight of the GMM's
    most likely component at each step (T,) and its index (T,)."""
    out, _ = policy({k: v[None] for k, v in obs.items()})
    weights = torch.softmax(out.logits[0], -1)
    top, index = weights.max(-1)
    return policy.mode_action(out)[0], top, index


PHASES = ((-np.inf, -30, "more than 30 steps before the grasp"),
          (-30, -10, "30 to 10 steps before"),
          (-10, 0, "the last 10 steps before"),
          (0, 30, "the first 30 steps after"),
          (30, np.inf, "more than 30 steps after"))
"""Phases of a demo for ``--phases``: (from, to, label) in steps from its first grasp command."""


def grasp_steps(path: Path, demos: list[str]) -> dict[str, int]:
    """Each demo's index of its first closing grasp command (its length if it never closes)."""
    closes = {}
    with h5py.File(path, "r") as f:
        for name in demos:
            grasp = f[f"data/{name}/actions"][:, 6] > 0.5
            closes[name] = int(np.argmax(grasp)) if grasp.any() else len(grasp)
    return closes


def phases(where: np.ndarray, edges: list[int] | None = None
           ) -> Iterator[tuple[str, np.ndarray]]:
    """``PHASES``' labels (or, with ``edges``, the bins between consecutive edges) with the
    mask of the entries of ``where`` (steps from a demo's first grasp command) each holds;
    empty phases left out."""
    bins = PHASES if edges is None else [
        (low, high, f"{low} to {high} steps after")
        for low, high in zip(edges[:-1], edges[1:], strict=True)]
    for low, high, label in bins:
        here = (where >= low) & (where < high)
        if here.any():
            yield label, here


def position_errors_mm(estimate: torch.Tensor, truth: torch.Tensor) -> np.ndarray:
    """Each body's position error (..., bodies) in mm between two ``object_in_tcp`` values
    (..., 9k): an object head's estimate and the recorded poses."""
    error = (estimate - truth).double().numpy()
    error = error.reshape(*error.shape[:-1], -1, VALUES_PER_BODY["object_in_tcp"])[..., :3]
    return 1000 * np.linalg.norm(error, axis=-1)


def print_located(data: Path, demo: str, errors: np.ndarray, source: str) -> None:
    """Each object body's position error, ``errors`` (N, bodies) in mm, as read from
    ``source``: median and 90th percentile, the bodies named as ``demo`` records them."""
    with h5py.File(data, "r") as f:
        names = json.loads(f[f"data/{demo}"].attrs["object_bodies"])
    for body, name in enumerate(names):
        print(f"  the {name} located from {source}: position error median "
              f"{np.median(errors[:, body]):.1f} mm, 90th percentile "
              f"{np.percentile(errors[:, body], 90):.1f} mm")


def located_in(errors: np.ndarray, here: np.ndarray) -> str:
    """The bodies' median position errors over the entries ``here``, for a phase's line."""
    return (", objects located to " + ", ".join(
        f"{np.median(errors[here, body]):.1f}" for body in range(errors.shape[1]))
        + " mm (median, in the order above)")


def _numbers(parser: argparse.ArgumentParser, flag: str, text: str, kind: type) -> list:
    """The comma-separated numbers of ``flag`` (a one-line parser error otherwise)."""
    try:
        return [kind(s) for s in text.split(",") if s.strip()]
    except ValueError:
        parser.error(f"{flag} takes comma-separated {kind.__name__} values, got {text!r}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("checkpoint", type=Path, help="a LEGATO or BC-RNN checkpoint")
    parser.add_argument("data", type=Path, help="its demonstrations (HDF5)")
    parser.add_argument("--split", choices=SPLITS, default="valid")
    parser.add_argument("--windows", type=int, default=100, help="windows sampled (100)")
    parser.add_argument("--shifts", default="",
                        help="comma-separated pixel shifts of the frames, e.g. 4,10,20 "
                             "(image checkpoints only)")
    parser.add_argument("--moves", default="",
                        help="comma-separated object moves in mm, e.g. 10,25,50, the frames "
                             "rendered again (image checkpoints only)")
    parser.add_argument("--offsets", default="",
                        help="comma-separated object offsets in mm, e.g. 5,10,25 (state "
                             "checkpoints reading object_in_tcp only)")
    parser.add_argument("--phases", action="store_true",
                        help="break the errors down by steps from the demo's grasp")
    args = parser.parse_args()
    shifts = _numbers(parser, "--shifts", args.shifts, int)
    moves = _numbers(parser, "--moves", args.moves, float)
    offsets = _numbers(parser, "--offsets", args.offsets, float)
    torch.set_num_threads(1)
    ckpt = load_checkpoint(args.checkpoint)
    policy, cfg = ckpt.policy, ckpt.config
    if not isinstance(policy, RecurrentGMMPolicy):
        parser.error(f"{args.checkpoint} is a {cfg.algo} checkpoint, not LEGATO or BC-RNN "
                     f"(scripts/chunk_fit.py fits Diffusion Policy checkpoints)")
    image_keys = [k for k in cfg.obs_keys if k in IMAGE_KEYS]
    for flag, values in (("--shifts", shifts), ("--moves", moves)):
        if values and not image_keys:
            parser.error(f"{flag} needs an image checkpoint; {args.checkpoint} reads "
                         f"{', '.join(cfg.obs_keys)}")
    if offsets and "object_in_tcp" not in cfg.obs_keys:
        parser.error(f"--offsets needs a state checkpoint reading object_in_tcp; "
                     f"{args.checkpoint} reads {', '.join(cfg.obs_keys)}")
    policy.eval()
    located = policy.object_head is not None
    keys = (*cfg.obs_keys, "object_in_tcp") if located else cfg.obs_keys
    data = DemoSequenceDataset(args.data, keys, cfg.seq_length, args.split)
    rng = np.random.default_rng(0)
    picks = rng.permutation(len(data))[:args.windows]
    trans, rot, step, agree = [], [], [], []
    top_weight, switched, jumps = [], [], []  # the GMM's most likely component, per step
    labels = [f"frames shifted {k} px" for k in shifts] + \
        [f"objects moved {k:g} mm" for k in offsets]
    moved_labels = [f"objects moved {k:g} mm, frames rendered again" for k in moves]
    renderer = SceneRenderer(args.data, image_keys) if moves else None
    moved: dict[str, list[float]] = {label: [] for label in labels + moved_labels}
    misplaced: list[np.ndarray] = []  # per step, each body's position error (mm)
    redrawn: list[float] = []  # per frame, the fraction of pixels rendering again changed
    closes = grasp_steps(args.data, data.demos) if args.phases else {}
    from_grasp: list[np.ndarray] = []  # per step, its index relative to the demo's grasp
    peaks: dict[str, list[np.ndarray]] = {k: [] for k in image_keys}  # keypoints' top weights
    with torch.no_grad():
        for i in picks:
            item = data[int(i)]
            mask = item["pad_mask"].numpy()
            shown = item["actions"].double().numpy()[mask]
            acted, top, index = predict_with_modes(policy, item["obs"])
            acted, index = acted.double().numpy()[mask], index.numpy()[mask]
            top_weight += top.numpy()[mask].tolist()
            change = index[1:] != index[:-1]
            switched += change.tolist()
            jumps += list(1000 * np.linalg.norm(np.diff(acted[:, :3], axis=0), axis=1)[change])
            trans += list(1000 * np.linalg.norm(acted[:, :3] - shown[:, :3], axis=1))
            rot += list(np.degrees(np.linalg.norm(acted[:, 3:6] - shown[:, 3:6], axis=1)))
            step += list(1000 * np.linalg.norm(shown[:, :3], axis=1))
            agree += list(acted[:, 6] == (shown[:, 6] > 0.5))
            if closes:
                name, start = data.window(int(i))
                from_grasp.append(start + np.flatnonzero(mask) - closes[name])
            for key in image_keys:
                attention = policy.encoders[key].keypoint_attention(item["obs"][key][mask])
                peaks[key].append(attention.amax(-1).flatten().numpy())
            if located:
                estimate = policy.estimate_objects({k: v[None] for k, v in item["obs"].items()})
                truth = item["obs"]["object_in_tcp"]
                misplaced.append(position_errors_mm(estimate[0], truth)[mask])
            # One random direction per window for every perturbation of it.
            angle = rng.uniform(0, 2 * np.pi)
            direction = rng.normal(size=3) if offsets or moves else np.zeros(3)
            direction /= max(np.linalg.norm(direction), 1e-12)
            perturbed = [{key: shift_frames(v, round(k * np.sin(angle)), round(k * np.cos(angle)))
                          if key in image_keys else v for key, v in item["obs"].items()}
                         for k in shifts]
            perturbed += [{key: offset_objects(v, k / 1000 * direction)
                           if key == "object_in_tcp" else v for key, v in item["obs"].items()}
                          for k in offsets]
            if renderer is not None:
                # Against the same frames rendered unmoved, so that only the move differs.
                name, start = data.window(int(i))
                steps = np.minimum(np.arange(start, start + cfg.seq_length),
                                   start + int(mask.sum()) - 1)
                rendered = [{**item["obs"], **renderer.frames(name, steps, k / 1000 * direction)}
                            for k in (0.0, *moves)]
                acted_here = predict(policy, rendered[0]).double().numpy()[mask]
                for key in image_keys:  # how well rendering again reproduces the recording
                    redrawn += list((rendered[0][key] != item["obs"][key])[mask]
                                    .flatten(1).float().mean(1).numpy())
                for label, obs in zip(moved_labels, rendered[1:], strict=True):
                    answer = predict(policy, obs).double().numpy()[mask]
                    moved[label] += list(1000 * np.linalg.norm(answer[:, :3] - acted_here[:, :3],
                                                               axis=1))
            for label, obs in zip(labels, perturbed, strict=True):
                answer = predict(policy, obs).double().numpy()[mask]
                moved[label] += list(1000 * np.linalg.norm(answer[:, :3] - acted[:, :3], axis=1))
    print(f"{args.checkpoint} on the {args.split} demos of {args.data}: {len(picks)} windows, "
          f"{len(trans)} steps")
    print(f"  translation error median {np.median(trans):.2f} mm, 90th percentile "
          f"{np.percentile(trans, 90):.2f} mm (the demonstrated step: median "
          f"{np.median(step):.2f} mm)")
    print(f"  rotation error median {np.median(rot):.2f} deg, 90th percentile "
          f"{np.percentile(rot, 90):.2f} deg")
    print(f"  grasp agreement {np.mean(agree):.3f}")
    print(f"  the most likely of the GMM's {cfg.gmm_modes} components: its weight median "
          f"{np.median(top_weight):.2f} (10th percentile {np.percentile(top_weight, 10):.2f}); "
          f"it changes at {100 * np.mean(switched):.1f} % of consecutive steps, where the "
          f"translation acted on moves by a median "
          f"{np.median(jumps) if jumps else 0.0:.2f} mm")
    for key, values in peaks.items():
        print(f"  {key} keypoints: the largest softmax weight median "
              f"{np.median(np.concatenate(values)):.3f}")
    errors = np.concatenate(misplaced) if misplaced else None
    if errors is not None:
        print_located(args.data, data.demos[0], errors, "the frames")
    if from_grasp:
        where = np.concatenate(from_grasp)
        trans_mm, step_mm = np.asarray(trans), np.asarray(step)
        print("  by phase (steps from the demo's first grasp command):")
        for label, here in phases(where):
            line = (f"    {label}: {here.sum()} steps, translation error median "
                    f"{np.median(trans_mm[here]):.2f} mm (the demonstrated step "
                    f"{np.median(step_mm[here]):.2f} mm)")
            print(line + (located_in(errors, here) if errors is not None else ""))
    if redrawn:
        print(f"  frames rendered again from the recorded states: {100 * np.median(redrawn):.2f} % "
              f"of a frame's pixels differ from the recorded frame (median; max "
              f"{100 * np.max(redrawn):.2f} %)")
    for label, values in moved.items():
        print(f"  {label}: the translation moves median {np.median(values):.2f} mm, "
              f"90th percentile {np.percentile(values, 90):.2f} mm")


if __name__ == "__main__":
    main()
