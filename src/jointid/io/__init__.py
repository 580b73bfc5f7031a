"""jointid.io: file formats (UFF58, CSV, impact records), atomic files and the output-directory writer.

The main API, re-exported here (imported on first use)::

    from jointid.io import read_frf, write_frf, OutputSet

* :mod:`.frf_files` -- ``read_frf``, ``write_frf`` (format from the extension);
* :mod:`.uff` -- ``read_uff_frf``, ``write_uff_frf``; :mod:`.frf_csv` -- ``read_frf_csv``,
  ``write_frf_csv``;
* :mod:`.output_dir` -- ``OutputSet`` (the ``--out DIR`` writer), ``OutputError``;
* :mod:`.tables` -- ``write_csv``; :mod:`.json_files` -- ``json_text`` (strict JSON); :mod:`.atomic` -- ``atomic_write_text``,
  ``atomic_write_bytes``, ``atomic_path``; :mod:`.png` -- ``figure_png`` (a matplotlib figure as PNG bytes, laid
  out once: every figure jointid writes goes through it).
"""

from .._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        ".frf_files": ("read_frf", "write_frf"),
        ".uff": ("read_uff_frf", "write_uff_frf"),
        ".frf_csv": ("read_frf_csv", "write_frf_csv"),
        ".output_dir": ("OutputSet", "OutputError"),
        ".tables": ("write_csv",),
        ".json_files": ("json_text", "strict_json"),
        ".atomic": ("atomic_write_text", "atomic_write_bytes", "atomic_path"),
        ".png": ("figure_png",),
    },
    submodules=("frf_files", "uff", "frf_csv", "output_dir", "tables", "json_files", "atomic", "png"),
)
