r"""Pipelines: a method that chains library stages, measurements to track, in one call.

Some methods of the book are not one filter but a chain: clean the measurements, compute least-squares fixes,
filter the fixes, or start a filter from a fix. Each stage is an ordinary library call that a chapter can also
run on its own; a pipeline only wires them, keeps every intermediate result, and so makes the whole method one
call for a Monte Carlo study. Pipelines sit above the filters and least squares in the library's layers
(``tests/test_layers.py``): a filter never imports least squares.

=================================  ==============================================================================
:func:`.prepositioned_bias_ekf`    paper A: precision factor along the provisional track -> least-squares fix of
                                   position and bias -> bias EKF from the fix (:mod:`.prepositioned`)
:func:`.ls_fading_ekf`             paper D: grid pre-location of start and sound-speed factor -> acceptance after a
                                   turn -> fading EKF from it (:mod:`.ls_fading`)
:func:`.filter_from_start_epochs`  any filter started at each run's own epoch (:mod:`.staggered`)
:func:`.or_vmlbl_kf`               paper E: range filter with outlier rejection -> virtual-beacon least squares on
                                   the last four epochs -> cascade Kalman filter on the fixes (:mod:`.vmlbl`)
:func:`.epoch_windows`             the epochs of each virtual-beacon fix
:func:`.vmlbl_error_budget`        paper E's Fig. 6: Monte Carlo of the fix's error against each error source
:func:`.run_depth_study`           paper C's comparison: every depth filter on every run of a profile
                                   (:mod:`.depth_study`)
=================================  ==============================================================================
"""

from .depth_study import DepthStudy, run_depth_study
from .ls_fading import LSFadingResult, ls_fading_ekf
from .prepositioned import prepositioned_bias_ekf
from .staggered import StaggeredRun, filter_from_start_epochs
from .vmlbl import (ERROR_SOURCES, ErrorBudget, NoUsableFixError, VMLBLResult, epoch_windows, or_vmlbl_kf,
                    vmlbl_error_budget)

__all__ = ["prepositioned_bias_ekf", "ls_fading_ekf", "LSFadingResult", "filter_from_start_epochs", "StaggeredRun",
           "or_vmlbl_kf", "VMLBLResult", "NoUsableFixError", "epoch_windows", "vmlbl_error_budget", "ErrorBudget",
           "ERROR_SOURCES",
           "run_depth_study", "DepthStudy"]
