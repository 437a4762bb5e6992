"""JOSHUA's simulation modes OFFSCREEN, PASSIVE and INTERACTIVE, plus the pieces other modes reuse.

- `joshua_modes.offscreen`: `run_offscreen` (frames of a replayed trajectory) and `iter_offscreen_frames`.
- `joshua_modes.interactive`: `run_interactive` (the MuJoCo viewer, arm held at a keyframe).
- `joshua_modes.validation`: the trajectory checks against a model (the CSV reader is `joshua_core.trajectory`).
- `joshua_modes.video.VideoWriter` and `joshua_modes.display.open_display`: MP4 writing and
  "viewer window or headless recording", shared with other mode plugins.

The package itself imports nothing heavy; the `joshua` entry point is `joshua_modes.plugin`.
"""
