"""Units of UFF dataset 58 FRF records: the units dataset 164 and the axis units labels.

Rules (what :mod:`jointid.io.uff` applies to every FRF record it keeps)
----------------------------------------------------------------------
* **Labels first.** The ordinate numerator (record 9) and denominator
  (record 10) units labels say what the numbers are in. Known labels
  (case-insensitive, spaces ignored; ``s2`` = ``s^2``):

  ============  =====================================================
  acceleration  ``g`` (9.80665 m/s^2), ``m/s^2``, ``cm/s^2``, ``mm/s^2``, ``in/s^2``, ``ft/s^2``
  velocity      ``m/s``, ``cm/s``, ``mm/s``, ``in/s``, ``ft/s``
  displacement  ``m``, ``cm``, ``mm``, ``um`` (``µm``), ``in``, ``ft``
  force         ``N``, ``kN``, ``mN`` (exactly so: ``MN`` is refused), ``lbf``, ``kgf``
  ============  =====================================================

  with ``in`` = 0.0254 m, ``ft`` = 0.3048 m, ``lbf`` = 4.4482216152605 N,
  ``kgf`` = 9.80665 N (exact definitions). The numerator label may carry
  the force too: ``g/N``, ``(m/s^2)/N``, ``m/s^2/N``, ``mm/N``; the
  denominator label must then be blank or the same force.
* A label of another quantity than the record's data type (``m/s`` on an
  acceleration numerator, 12; a motion on the force denominator, 13), or a
  label not in the table, is a :class:`~jointid.errors.DataError` naming the
  file and the record: jointid never guesses a unit.
* **Blank labels** (empty or ``NONE``) take the units of the file's dataset
  164 (the last one before the record), or SI when the file has none.
* **Dataset 164** gives a units code and factors *file unit -> SI* (divide
  by them): codes 1 SI (m, N), 2 BG (ft, lbf), 3 MG (m, kgf), 4 BA (ft,
  poundal), 5 MM (mm, mN), 6 CM (cm, cN), 7 IN (in, lbf), 8 GM (mm, kgf)
  use their exact definitions, and factors that contradict the code are an
  error; 9 (user defined) uses the file's factors (1.0 and 1.0 is SI).
  A label that names a length or force other than a non-SI dataset 164's is
  a contradiction and an error; with an SI dataset 164 (which exporters
  write by default) the labels are taken as they are.
* **Rotations and moments.** A rotational response (UFF directions 4-6)
  has no length: its labels are ``rad``, ``rad/s``, ``rad/s^2`` (or
  ``deg`` ones, x pi/180), a blank label is radians whatever dataset 164
  says, and a translation's label on it (``g``, ``mm/s^2``) is an error
  (and the reverse). A moment excitation (reference directions 4-6) is in
  ``N*m``, ``kN*m``, ``lbf*in``, ``lbf*ft``, or blank: the file's force
  times length unit. jointid writes ``rad/s^2`` and ``N*m`` for them.
* The abscissa (record 8) is in Hz: label blank, ``Hz`` or ``kHz``.

Time records (function type 1, :func:`signal_units`)
----------------------------------------------------
A time record is one signal: its ordinate label (record 9) names the unit of
that signal alone, a force (data type 13: ``N``, ``kN``, ``mN``, ``lbf``,
``kgf``) or a motion of the record's data type (12, 11, 8: the motion labels
of the table above, without a force), with the same rules for blank labels,
dataset 164 and contradictions. The abscissa is time: label blank, ``s`` or
``ms`` (:func:`time_factor`). :func:`conversion_line` says in one line what
was converted.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

__all__ = ["G0", "INCH", "FOOT", "LBF", "KGF", "UnitSystem", "SI", "units_from_164", "ordinate_units", "abscissa_factor", "OrdinateUnits",
           "signal_units", "time_factor", "conversion_line"]

G0 = 9.80665  # m/s^2, standard gravity (exact)
INCH = 0.0254  # m (exact)
FOOT = 0.3048  # m (exact)
LBF = 4.4482216152605  # N (exact: 0.45359237 kg * G0)
KGF = G0  # N
POUNDAL = 0.45359237 * FOOT  # N (exact)

# label -> (quantity, SI factor, length unit name or None)
_ACC, _VEL, _DISP, _FORCE = "acceleration", "velocity", "displacement", "force"
_LENGTHS = {"m": 1.0, "cm": 0.01, "mm": 1e-3, "um": 1e-6, "in": INCH, "ft": FOOT}
_MOTION: dict[str, tuple[str, float, str | None]] = {"g": (_ACC, G0, None)}
for _name, _size in _LENGTHS.items():
    _MOTION[_name] = (_DISP, _size, _name)
    if _name != "um":
        _MOTION[f"{_name}/s"] = (_VEL, _size, _name)
        _MOTION[f"{_name}/s^2"] = (_ACC, _size, _name)
_FORCES = {"n": 1.0, "kn": 1e3, "mN": 1e-3, "lbf": LBF, "kgf": KGF}
# a rotational response (UFF directions 4-6): angle labels, no length (its unit does not depend on dataset 164)
_ROTATION: dict[str, tuple[str, float, str | None]] = {}
for _name, _size in {"rad": 1.0, "deg": math.pi / 180.0}.items():
    _ROTATION[_name] = (_DISP, _size, None)
    _ROTATION[f"{_name}/s"] = (_VEL, _size, None)
    _ROTATION[f"{_name}/s^2"] = (_ACC, _size, None)
# a moment excitation (reference directions 4-6): force times length
_MOMENTS = {"n*m": 1.0, "nm": 1.0, "n-m": 1.0, "n.m": 1.0, "kn*m": 1e3, "lbf*in": LBF * INCH, "in*lbf": LBF * INCH,
            "lbf-in": LBF * INCH, "in-lbf": LBF * INCH, "lbf*ft": LBF * FOOT, "ft*lbf": LBF * FOOT}
_DATA_QUANTITY = {8: _DISP, 11: _VEL, 12: _ACC, 13: _FORCE}

# units code -> (name, length unit size m, force unit size N, length unit name, force unit name)
_SYSTEMS = {
    1: ("SI", 1.0, 1.0, "m", "N"),
    2: ("BG", FOOT, LBF, "ft", "lbf"),
    3: ("MG", 1.0, KGF, "m", "kgf"),
    4: ("BA", FOOT, POUNDAL, "ft", "poundal"),
    5: ("MM", 1e-3, 1e-3, "mm", "mN"),
    6: ("CM", 1e-2, 1e-2, "cm", "cN"),
    7: ("IN", INCH, LBF, "in", "lbf"),
    8: ("GM", 1e-3, KGF, "mm", "kgf"),
}


@dataclass(frozen=True)
class UnitSystem:
    """The units of a UFF file (dataset 164): size of its length and force units in SI."""

    name: str
    length_m: float = 1.0
    force_n: float = 1.0
    length_name: str = "m"
    force_name: str = "N"
    record: int | None = None  # dataset 164 record number, None: no dataset 164

    @property
    def is_si(self) -> bool:
        return self.length_m == 1.0 and self.force_n == 1.0

    def describe(self) -> str:
        where = "no units dataset 164" if self.record is None else f"units dataset 164 (record {self.record})"
        return f"{where}: {self.name}, {self.length_name} and {self.force_name}"


SI = UnitSystem("SI")


def units_from_164(d: dict, where: str, record: int) -> UnitSystem:
    """The :class:`UnitSystem` of a pyuff dataset 164 dict; ``where`` names the file and record in errors.

    Raises
    ------
    DataError
        Unknown units code, non-positive factors, or factors that contradict a standard code.
    """
    from ..errors import DataError

    code = d.get("units_code")
    desc = str(d.get("units_description", "")).strip()
    try:
        lf, ff = float(d.get("length")), float(d.get("force"))
    except (TypeError, ValueError):
        raise DataError(f"{where}: units dataset 164 has no readable length/force factors") from None
    if not (math.isfinite(lf) and math.isfinite(ff) and lf > 0 and ff > 0):
        raise DataError(f"{where}: units dataset 164 has length factor {lf!r} and force factor {ff!r}; both must be positive")
    if code == 9:
        length_m, force_n = 1.0 / lf, 1.0 / ff
        if abs(lf - 1.0) <= 1e-12 and abs(ff - 1.0) <= 1e-12:
            return UnitSystem("user defined (SI)", 1.0, 1.0, "m", "N", record)
        return UnitSystem(f"user defined {desc!r}" if desc else "user defined", length_m, force_n,
                          f"{length_m:.10g} m", f"{force_n:.10g} N", record)
    if code not in _SYSTEMS:
        raise DataError(
            f"{where}: units dataset 164 declares units code {code!r} ({desc!r}); expected 1 (SI) to 9 (user defined)"
        )
    name, length_m, force_n, lname, fname = _SYSTEMS[code]
    for what, factor, size in (("length", lf, length_m), ("force", ff, force_n)):
        if abs(factor * size - 1.0) > 1e-5:
            raise DataError(
                f"{where}: units dataset 164 declares code {code} ({name}: {lname}, {fname}) but a {what} factor "
                f"{factor:.10g} (expected {1.0 / size:.10g}); the file contradicts itself: fix the code or the factor"
            )
    return UnitSystem(name, length_m, force_n, lname, fname, record)


def _norm(label: str) -> str:
    s = re.sub(r"\s+", "", label).replace("²", "^2").replace("**", "^").replace("µ", "u").replace("μ", "u")
    s = re.sub(r"/sec", "/s", s, flags=re.IGNORECASE)
    s = re.sub(r"/s2$", "/s^2", s, flags=re.IGNORECASE)
    s = re.sub(r"/s/s$", "/s^2", s, flags=re.IGNORECASE)
    return s


def _blank(label) -> bool:
    return label is None or str(label).strip() == "" or str(label).strip().upper() == "NONE"


def _force(label: str) -> float | None:
    s = _norm(label)
    if s == "mN":
        return _FORCES["mN"]
    if s.lower() == "mn":  # MN, Mn: mega-newton or a typo; never read as milli
        return None
    return _FORCES.get(s.lower())


def _motion(label: str, rotation: bool = False) -> tuple[str, float, str | None] | None:
    s = label.strip()
    if s.startswith("(") and s.endswith(")"):
        s = s[1:-1]
    return (_ROTATION if rotation else _MOTION).get(_norm(s).lower())


def _excitation(label: str, moment: bool) -> float | None:
    """SI factor of a force (or, ``moment``, a force-times-length) label, None when it is not one."""
    return _MOMENTS.get(_norm(label).lower()) if moment else _force(label)


@dataclass(frozen=True)
class OrdinateUnits:
    """The units of one FRF record: SI factor and a short text of what the file holds."""

    factor: float
    text: str  # e.g. "g/N", "mm/s^2 over N"
    source: str  # "labels", "dataset 164", "default SI"


def ordinate_units(d: dict, num_type: int, system: UnitSystem, where: str, rotation: bool = False,
                   moment: bool = False) -> OrdinateUnits:
    """SI factor of a dataset 58 FRF record from its units labels (or the file's units).

    A rotational response (``rotation``: ``rad``, ``rad/s``, ``rad/s^2``, or ``deg`` ones) has no length: the
    file's length unit does not apply to it, and a length label on it is an error; a moment excitation
    (``moment``: ``N*m``, ``kN*m``, ``lbf*in``, ``lbf*ft``) is in the file's force times length unit.

    Parameters
    ----------
    d : dict
        pyuff dataset 58 dict (``ordinate_axis_units_lab``, ``orddenom_axis_units_lab``).
    num_type : int
        Ordinate numerator specific data type (8, 11 or 12; the denominator is force, 13).
    system : UnitSystem
        Units in effect (the last dataset 164 before the record, or :data:`SI`).
    where : str
        File and record, for error messages.

    Returns
    -------
    OrdinateUnits
        ``factor`` such that ``value_SI = factor * value_file`` (SI: (m/s^n)/N).
    """
    from ..errors import DataError

    quantity = _DATA_QUANTITY[num_type]
    num_lab, den_lab = d.get("ordinate_axis_units_lab"), d.get("orddenom_axis_units_lab")
    num: tuple[str, float, str | None] | None = None
    num_text = ""
    den: float | None = None
    den_text = None
    response = "a rotation" if rotation else "a translation"
    if not _blank(num_lab):
        lab = str(num_lab).strip()
        num, num_text = _motion(lab, rotation), lab
        if num is None and "/" in lab:  # composite "g/N", "(m/s^2)/N", "mm/N"
            left, right = lab.rsplit("/", 1)
            f = _excitation(right, moment)
            m = _motion(left, rotation)
            if f is not None and m is not None:
                num, den, den_text = m, f, right.strip()
                num_text = left.strip()
                if num_text.startswith("(") and num_text.endswith(")"):
                    num_text = num_text[1:-1].strip()
        if num is None and (_motion(lab, not rotation) is not None
                            or ("/" in lab and _motion(lab.rsplit("/", 1)[0], not rotation) is not None)):
            raise DataError(f"{where}: ordinate units label {lab!r} is for {'a translation' if rotation else 'a rotation'}, "
                            f"but the response is {response}; fix the label (e.g. "
                            f"{'rad/s^2' if rotation else 'm/s^2'})")
        if num is None:
            if _force(lab) is not None:
                raise DataError(
                    f"{where}: ordinate units label {lab!r} is a force, but the ordinate numerator data type is "
                    f"{num_type} ({quantity}); fix the label or the data type"
                )
            raise DataError(
                f"{where}: unknown ordinate units label {lab!r}; jointid reads g, m/s^2, mm/s^2, in/s^2, m/s, mm/s, "
                "in/s, m, mm, in (optionally over N, kN, lbf: 'g/N'); fix the label in the file"
            )
        if num[0] != quantity:
            raise DataError(
                f"{where}: ordinate units label {lab!r} ({num[0]}) contradicts the ordinate numerator data type "
                f"{num_type} ({quantity}); fix the label or the data type"
            )
    if not _blank(den_lab):
        lab = str(den_lab).strip()
        f = _excitation(lab, moment)
        if f is None:
            if moment:
                raise DataError(f"{where}: ordinate denominator units label {lab!r}: the excitation is a moment; jointid "
                                "reads N*m, kN*m, lbf*in, lbf*ft")
            what = "a motion" if _motion(lab) is not None else "an unknown unit"
            raise DataError(
                f"{where}: ordinate denominator units label {lab!r} is {what}, but the denominator data type is "
                "13 (excitation force); jointid reads N, kN, mN, lbf, kgf"
            )
        if den is not None and f != den:
            raise DataError(
                f"{where}: ordinate units label {str(num_lab).strip()!r} says force in {den_text!r} but the "
                f"denominator units label says {lab!r}; fix one of them"
            )
        den, den_text = f, lab
    if not system.is_si:  # a deliberate non-SI dataset 164: labels must agree with it
        if num is not None and num[2] is not None and abs(_LENGTHS[num[2]] / system.length_m - 1.0) > 1e-9:
            raise DataError(
                f"{where}: ordinate units label {str(num_lab).strip()!r} (length in {num[2]}) contradicts the file's "
                f"{system.describe()}; fix the label or the units dataset"
            )
        if den is not None and abs(den / (system.force_n * (system.length_m if moment else 1.0)) - 1.0) > 1e-9:
            raise DataError(
                f"{where}: force units label {den_text!r} contradicts the file's {system.describe()}; "
                "fix the label or the units dataset"
            )
    fallback = "dataset 164" if system.record is not None else "default SI"
    if num is None and rotation:  # an angle has no length unit: radians whatever dataset 164 says
        num_factor, num_text, num_src = 1.0, f"rad{_SUFFIX[quantity]}", fallback
    elif num is None:
        num_factor, num_text, num_src = system.length_m, f"{system.length_name}{_SUFFIX[quantity]}", fallback
    else:
        num_factor, num_src = num[1], "labels"
    if den is None and moment:
        den_factor, den_text, den_src = system.force_n * system.length_m, f"{system.force_name}*{system.length_name}", fallback
    elif den is None:
        den_factor, den_text, den_src = system.force_n, system.force_name, fallback
    else:
        den_factor, den_src = den, "labels"
    text = f"({num_text})/{den_text}" if "/" in num_text else f"{num_text}/{den_text}"
    source = num_src if num_src == den_src else f"{num_src} and {den_src}"
    return OrdinateUnits(num_factor / den_factor, text, source)


_SUFFIX = {_DISP: "", _VEL: "/s", _ACC: "/s^2"}


def abscissa_factor(d: dict, where: str) -> float:
    """Factor to Hz of a record's abscissa units label (blank, ``Hz``: 1; ``kHz``: 1000)."""
    from ..errors import DataError

    lab = d.get("abscissa_axis_units_lab")
    if _blank(lab):
        return 1.0
    s = _norm(str(lab)).lower()
    if s == "hz":
        return 1.0
    if s == "khz":
        return 1e3
    raise DataError(f"{where}: abscissa units label {str(lab).strip()!r} is not a frequency; expected Hz")


def signal_units(d: dict, data_type: int, system: UnitSystem, where: str) -> OrdinateUnits:
    """SI factor of a dataset 58 time record (one signal) from its ordinate units label (or the file's units).

    Parameters
    ----------
    d : dict
        pyuff dataset 58 dict (``ordinate_axis_units_lab``).
    data_type : int
        Ordinate specific data type: 13 (excitation force), 12 (acceleration),
        11 (velocity) or 8 (displacement).
    system : UnitSystem
        Units in effect (the last dataset 164 before the record, or :data:`SI`).
    where : str
        File and record, for error messages.

    Returns
    -------
    OrdinateUnits
        ``factor`` such that ``value_SI = factor * value_file`` (N, m/s^2, m/s or m).

    Raises
    ------
    DataError
        An unknown label, a label of another quantity than ``data_type``, or one
        that contradicts a non-SI dataset 164 (naming ``where``).
    """
    from ..errors import DataError

    quantity = _DATA_QUANTITY[data_type]
    lab = d.get("ordinate_axis_units_lab")
    fallback = "dataset 164" if system.record is not None else "default SI"
    if _blank(lab):
        if quantity == _FORCE:
            return OrdinateUnits(system.force_n, system.force_name, fallback)
        return OrdinateUnits(system.length_m, f"{system.length_name}{_SUFFIX[quantity]}", fallback)
    lab = str(lab).strip()
    if quantity == _FORCE:
        f = _force(lab)
        if f is None:
            what = "a motion" if _motion(lab) is not None else "an unknown unit"
            raise DataError(
                f"{where}: ordinate units label {lab!r} is {what}, but the record is an excitation force "
                "(data type 13); jointid reads N, kN, mN, lbf, kgf: fix the label in the file"
            )
        if not system.is_si and abs(f / system.force_n - 1.0) > 1e-9:
            raise DataError(f"{where}: force units label {lab!r} contradicts the file's {system.describe()}; "
                            "fix the label or the units dataset")
        return OrdinateUnits(f, lab, "labels")
    m = _motion(lab)
    if m is None:
        if _force(lab) is not None:
            raise DataError(f"{where}: ordinate units label {lab!r} is a force, but the record's data type is "
                            f"{data_type} ({quantity}); fix the label or the data type")
        raise DataError(
            f"{where}: unknown ordinate units label {lab!r}; jointid reads g, m/s^2, mm/s^2, in/s^2, m/s, mm/s, "
            "in/s, m, mm, in (and cm, um, ft): fix the label in the file"
        )
    if m[0] != quantity:
        raise DataError(f"{where}: ordinate units label {lab!r} ({m[0]}) contradicts the record's data type "
                        f"{data_type} ({quantity}); fix the label or the data type")
    if not system.is_si and m[2] is not None and abs(_LENGTHS[m[2]] / system.length_m - 1.0) > 1e-9:
        raise DataError(f"{where}: ordinate units label {lab!r} (length in {m[2]}) contradicts the file's "
                        f"{system.describe()}; fix the label or the units dataset")
    return OrdinateUnits(m[1], lab, "labels")


def time_factor(d: dict, where: str) -> float:
    """Factor to seconds of a time record's abscissa units label (blank, ``s``: 1; ``ms``: 1e-3)."""
    from ..errors import DataError

    lab = d.get("abscissa_axis_units_lab")
    if _blank(lab):
        return 1.0
    s = _norm(str(lab)).lower()
    if s in ("s", "sec", "second", "seconds"):
        return 1.0
    if s == "ms":
        return 1e-3
    raise DataError(f"{where}: abscissa units label {str(lab).strip()!r} is not a time; expected s or ms")


def conversion_line(groups: dict[tuple[str, str, float], int]) -> str | None:
    """One line on what was converted to SI, e.g. ``units: 20 response records in g (labels) converted to SI: x 9.80665``.

    Parameters
    ----------
    groups : dict
        ``(what, "unit (source)", factor) -> number of records``; ``what`` names
        the records (``"force"``, ``"response"``). Groups already in SI are left
        out; records with no label and no dataset 164 are said to be read as SI.

    Returns
    -------
    str or None
        None when every record was in SI (labelled or from an SI dataset 164).
    """
    parts = []
    for (what, text, factor), n in groups.items():
        noun = f"{n} {what} record{'s' if n != 1 else ''}"
        if text.endswith("(default SI)"):
            parts.append(f"{noun} without units labels (and no units dataset 164) read as SI {text.split(' (')[0]}")
        elif factor != 1.0:
            parts.append(f"{noun} in {text} converted to SI: x {factor:.15g}")
    return "units: " + "; ".join(parts) if parts else None
