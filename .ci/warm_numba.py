"""Compile umbmark's numba kernels into their on-disk caches, once.

CI runs this beside the quality gates (which leave the second core idle), so that the test
processes load the compiled kernels instead of each compiling them at the same time.
"""

from umbmark.correct.exact import exact_correction
from umbmark.model.batch import simulate_batch
from umbmark.model.drive import EXAMPLE_ROBOT, mixed_program, simulate_drive
from umbmark.model.geometry import LABMATE, ErrorParams
from umbmark.realrobot.scanmatch import match_consecutive

(runs,) = simulate_batch([ErrorParams(ed=1.01, eb=1.02)], side_m=2.0, n_runs=2, noise="paper", engine="numba")
exact_correction(runs, 2.0, LABMATE.wheelbase_m)
log = simulate_drive(mixed_program(3.0, seed=1), EXAMPLE_ROBOT, seed=1)  # the ray caster
match_consecutive(log.ranges_m[:4], log.angles_rad)
