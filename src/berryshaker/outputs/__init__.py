"""Safe output: a file appears complete or not at all, and nothing the user made is ever overwritten or removed.

* :func:`check_output_file` and :func:`prepare_output_dir` check a destination *before* any work and raise
  :class:`berryshaker.errors.OutputError` with the reason and what to do (:mod:`.destinations`).
* A folder of outputs is filled in a hidden staging folder beside it (:func:`staged_directory`) and moved into
  place only when everything succeeded (:mod:`.staging`).  The finished folder carries a marker file
  (``.berryshaker-output.json``: per command -- ``kind``, e.g. ``"kinematics --plot"`` -- the files it wrote with
  their sha256; :mod:`.marker`), so a later run of the same command may replace exactly those files while they
  are unchanged -- and never a file the user put there or changed, a file another command wrote, or anything
  reached through a symlink.
* Single files are written atomically (:func:`write_text_atomic`, :func:`write_json_atomic`: strict JSON, a NaN
  is null), files that belong together all or none (:func:`write_files_atomic`), a failed write (a full disk) is
  one :class:`~berryshaker.errors.WriteError` (:mod:`.atomic_files`); a sheet and its printable copy are stamped so ``--force`` replaces only its own
  (:mod:`.paired_files`); every output records its provenance (:mod:`.provenance_record`).
* A run ``simulate --out`` saved is read back strictly by :func:`read_saved_run` (:mod:`.saved_run`).

The names callers use are importable from here.
"""

from berryshaker.outputs.atomic_files import (
    WRITE_ERRNOS,
    current_umask,
    file_sha256,
    finite_json,
    strict_json_text,
    write_bytes_atomic,
    write_error,
    write_files_atomic,
    write_json_atomic,
    write_text_atomic,
)
from berryshaker.outputs.destinations import check_output_file, prepare_output_dir
from berryshaker.outputs.marker import MARKER_NAME, marker_owners, read_output_marker
from berryshaker.outputs.paired_files import check_forced_pair, read_html_stamp, stamp_html
from berryshaker.outputs.provenance_record import code_fingerprint, provenance, write_provenance
from berryshaker.outputs.saved_run import SavedRun, read_saved_run, split_unit
from berryshaker.outputs.staging import (
    STAGING_TAG,
    STALE_FOREIGN_STAGING_HOURS,
    STALE_STAGING_HOURS,
    clean_stale_staging,
    pid_alive,
    staged_directory,
)

#: the public names
__all__ = ["MARKER_NAME", "SavedRun", "read_saved_run", "split_unit", "WRITE_ERRNOS", "STAGING_TAG", "STALE_FOREIGN_STAGING_HOURS", "STALE_STAGING_HOURS",
           "check_forced_pair", "check_output_file", "clean_stale_staging", "code_fingerprint", "current_umask", "file_sha256",
           "finite_json", "marker_owners", "pid_alive", "prepare_output_dir", "provenance", "read_html_stamp",
           "read_output_marker", "stamp_html", "staged_directory", "strict_json_text", "write_bytes_atomic",
           "write_error", "write_files_atomic", "write_json_atomic", "write_provenance", "write_text_atomic"]
