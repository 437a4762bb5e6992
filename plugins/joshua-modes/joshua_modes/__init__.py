"""JOSHUA's simulation modes OFFSCREEN, PASSIVE and INTERACTIVE, plus the pieces other modes reuse.

- `joshua_modes.offscreen`: `run_offscreen` (frames of a replayed trajectory) and `iter_offscreen_frames`.
- `joshua_modes.interactive`: `run_interactive` (the MuJoCo viewer, arm held at a keyframe).
- `joshua_modes.validation`: the trajectory checks against a model (the CSV reader is `joshua_core.trajectory`).

MP4 writing and "viewer window or headless recording" are in joshua-render (`joshua_render`), which
the modes, the mirror and the trainers share.

The package itself imports nothing heavy; the `joshua` entry point is `joshua_modes.plugin`.
"""
