"""A study's measured FRF file read as the study describes it (light: the readers of :mod:`jointid.io` only).

:func:`read_study_frf` is the read of :func:`jointid.pipeline.read_measured` without its check of the
study's DOFs. It imports no estimator, so ``jointid identify`` can run it in its figure worker
(:class:`~jointid.plots.figure_worker.FigureWorker`, ``first``) while it imports the estimators itself.
"""

from __future__ import annotations

import os

from ..frf import FRF

__all__ = ["read_study_frf"]


def read_study_frf(study, path: str | os.PathLike) -> FRF:
    """The observed x excited FRFs of ``path`` (and their coherence, when the file has it), in SI.

    ``[measurement].points`` maps the file's point ids to model nodes; how the file's directions
    map to the model's DOFs is the free structure's (``frf_reading``; see
    :func:`jointid.io.frf_files.read_frf`). ``FRF.notes`` says in one line each what was
    converted to SI and what was skipped.

    Parameters
    ----------
    study : Study
    path : path-like
        The FRF file (``.uff``, ``.unv``, ``.58``, ``.csv``).

    Raises
    ------
    DataError
        A record the study needs cannot be read (naming the file and the record).
    """
    from ..io.frf_files import read_frf

    m = study.measurement
    return read_frf(path, points=m.point_map, responses=m.observed_dofs, references=m.excited_dofs, coherence=True,
                    **study.structure.frf_reading(m))
