"""berryshaker: design and tune comb-oscillation blueberry harvesters with transmission clearance.

The package follows the physics chain of the reference study (see ``docs/study.md``):
``kinematics`` (cam, double rocker) -> ``contact`` (force laws, clearance joints) -> ``dynamics``
(MLSD clearance model) -> ... Everything inside is SI (m, s, rad, N); units are converted only at the
edges (config files, CLI).
"""

from importlib.metadata import PackageNotFoundError, version

from berryshaker.compiled_cache import point_numba_cache

# before any kernel is decorated: numba's cache folder is named by the compiled sources' digest (a stale entry of a
# kernel whose callee in another file changed would run the old code; berryshaker.compiled_cache)
point_numba_cache()

try:
    __version__ = version("berryshaker")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
