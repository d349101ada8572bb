"""Where a lid policy grasps the handle and where it sets the lid down, trial by trial.

    python scripts/lid_grasp_offsets.py CHECKPOINT [--embodiment abstract] [--seeds 20000-20007]
                                        [--json FILE]

Runs the checkpoint's policy in each scene (no cameras unless it is an image policy; the
default 3 cm lead bound) and samples the plant every 0.1 s. Per trial it prints, in the
pot's horizontal frame (cm):

* ``grasp``: the gripper's TCP minus the lid's centre when the policy first commands the
  fingers closed: where along the bar it took hold (the expert's grasps spread over
  ``GRASP_ALONG_BAR`` either way), and across it;
* ``height``: the TCP's height above the lid's centre then (cm), and ``at``: the seconds
  after homing when it did. A policy that closes on the bar does so at the bar's height
  soon after its approach; one that came down beside the bar is stopped lower, with a finger
  on the lid, and goes on pushing (the target held ``max_target_lead`` ahead) until it
  closes late or never;
* ``tcp at release``: the TCP's offset from the pot's axis when it first commands them open;
* ``lid``: the lid centre's final offset from the axis (3 cm passes), and the verdict.

An expert would set the TCP down at minus its grasp offset, so that the lid's centre lands on
the axis; a policy that does not answer the lid's offset in its fingers sets the TCP down
near the axis whatever its grasp, and one that answers it the wrong way adds the two.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from legato_drake import conventions
from legato_drake.cli import seed_list
from legato_drake.diagram import build_diagram
from legato_drake.episode import EpisodeRun
from legato_drake.errors import LegatoError
from legato_drake.learning.checkpoint import load_checkpoint
from legato_drake.pipelines.evaluate import trial_scenario


def trace(checkpoint: Path, embodiment: str, seed: int, image: bool) -> dict:
    """One trial's grasp offset, TCP offset at release and final lid offset (cm, xy)."""
    built = build_diagram(trial_scenario(embodiment, "lid", seed, checkpoint, camera=image,
                                         duration=None).validate())
    plant, task = built.plant, built.task
    run = EpisodeRun(built)
    grasp = release = at = None
    while not run.ended:
        run.advance_to(run.time + 0.1)
        context = plant.GetMyContextFromRoot(run.context)
        axis = task.pot_rim.CalcPoseInWorld(context).translation()[:2]
        tcp = built.robot.tcp_frame.CalcPoseInWorld(context).translation()
        lid = plant.EvalBodyPoseInWorld(context, task.lid).translation()
        closed = built.controller.GetOutputPort("action").Eval(
            built.controller.GetMyContextFromRoot(run.context))[6] > 0.5
        if closed and grasp is None:
            grasp = (tcp - lid) * 100  # x, y and the height above the lid's centre
            at = run.time - conventions.HOMING_DURATION
        if not closed and grasp is not None and release is None:
            release = (tcp[:2] - axis) * 100
    result = run.result()
    return {"seed": seed, "success": result.success, "reason": result.reason,
            "grasp_cm": None if grasp is None else grasp[:2].round(2).tolist(),
            "grasp_height_cm": None if grasp is None else round(float(grasp[2]), 2),
            "grasp_time_s": None if at is None else round(float(at), 1),
            "tcp_at_release_cm": None if release is None else release.round(2).tolist(),
            "lid_cm": ((lid[:2] - axis) * 100).round(2).tolist()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("checkpoint", type=Path, help="a lid policy, e.g. RUN/selected.pt")
    parser.add_argument("--embodiment", default="abstract")
    parser.add_argument("--seeds", type=seed_list, default=seed_list("20000-20007"),
                        help="scene seeds: N, A-B or A,B,C (default 20000-20007)")
    parser.add_argument("--json", type=Path, help="also write the rows here")
    args = parser.parse_args()
    try:
        ckpt = load_checkpoint(args.checkpoint)
    except LegatoError as e:
        sys.exit(f"error: {e}")
    image = ckpt.config.obs_mode == "image"
    rows = []
    print(f"{'seed':>6}  {'grasp (cm)':>14}  {'height':>6}  {'at (s)':>6}  {'tcp at release':>14}  "
          f"{'lid (cm)':>14}  verdict")
    for seed in args.seeds:
        row = trace(args.checkpoint, args.embodiment, seed, image)
        rows.append(row)
        cells = [" ".join(f"{v:+5.1f}" for v in row[k]) if row[k] else "-"
                 for k in ("grasp_cm", "tcp_at_release_cm", "lid_cm")]
        verdict = "ok" if row["success"] else row["reason"]
        height = "-" if row["grasp_height_cm"] is None else f"{row['grasp_height_cm']:+.1f}"
        at = "-" if row["grasp_time_s"] is None else f"{row['grasp_time_s']:.1f}"
        print(f"{seed:>6}  {cells[0]:>14}  {height:>6}  {at:>6}  {cells[1]:>14}  {cells[2]:>14}  "
              f"{verdict}")
    offsets = [float(np.linalg.norm(r["lid_cm"])) for r in rows]
    print(f"{sum(r['success'] for r in rows)}/{len(rows)} succeeded; lid offset median "
          f"{np.median(offsets):.1f} cm, max {max(offsets):.1f} cm")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
