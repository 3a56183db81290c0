"""Speed, position and braking for trains (seeds 004, 000 and 001).

* :mod:`motion.fusion` — :class:`~motion.fusion.TrackFilter`, the on-board
  fusion of accelerometer, delayed GNSS speed and track markers; its parts:
  :mod:`motion.model` (Kalman algebra), :mod:`motion.buffer` (replay buffer),
  :mod:`motion.policy` (GNSS acceptance), :mod:`motion.direction` (whether
  the sign of the speed is known), :mod:`motion.restart` (on-board restarts),
  :mod:`motion.state` (JSON snapshot), :mod:`motion.samples` (inputs, outputs, tuning and the
  motion-sample rules the API schema uses too).
* :mod:`motion.optical` — optical speed meters, equations (1)–(16) and
  Table 1 of seed 000, and the rolling-shutter smear meter on images.
* :mod:`motion.braking` — trials and exceedance bounds, protective section
  and braking start point, Monte Carlo of the braking-distance error.
* :mod:`motion.simulation` — generated train runs for tests and benchmarks
  (generator, runner, baselines, report).

Pure: numpy, OpenCV and the standard library only.
"""
