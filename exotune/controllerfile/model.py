"""The typed model of a validated controller file (docs/controller-file.md): :class:`ControllerFile`.

A controller file travels through the package as a frozen :class:`ControllerFile` whose attributes
carry the file's numbers in the file's units ([Hz], [s], [kg·m²], …), built by one function,
:meth:`ControllerFile.from_dict`, from the mapping that
:func:`~exotune.controllerfile.fileio.checked_controller` validated (the schema of
:mod:`~exotune.controllerfile.schema`, then :mod:`~exotune.controllerfile.checks`). Only this module
(with the schema and the writer, :mod:`~exotune.controllerfile.export`) spells the file's keys;
the rest of the package reads attributes, so a renamed key fails here, where the tests see it.

The numbers are the file's own (an integer written in a hand-edited file stays one). The mapping
itself stays available, unchanged, through :meth:`ControllerFile.to_dict` (a deep copy): to write
the file back byte-identically (:func:`~exotune.controllerfile.fileio.write_controller`) and for the
places that must hash or emit the exact mapping (the C code's traceability, the golden tests, the
JSON views).

Sections the file carries in design-file form or as untrusted predictions stay mappings: the
``certify`` families and ``implementation`` (parsed by :mod:`exotune.config`), ``predicted`` (compared
by ``certify`` as untrusted data), a filter's ``continuous`` block. A document under construction
(``export`` decides on it before its golden vectors and provenance exist) builds too: its missing
sections are empty.

References
----------
docs/controller-file.md (every field, its unit and meaning); docs/api.md#controller-files.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field, replace
from typing import Any, ClassVar, Mapping

__all__ = ["ControllerFile", "as_controller_file", "SampleRate", "Delay", "PlantSection", "DesignSection", "SixGains",
           "Filter", "RealizationFilter", "Realization", "Controller", "Dob", "ScheduleEntry", "GainSchedule",
           "Transmission", "CertifySection", "Requirements", "Predicted", "Golden", "Provenance", "Implementation", "nearest_index"]


def _value(q: Mapping) -> Any:
    return q["value"]


def _units(section: Mapping) -> dict[str, str]:
    return {k: q["unit"] for k, q in section.items() if isinstance(q, Mapping)}


def _rows(rows) -> tuple[tuple[float, ...], ...]:
    return tuple(tuple(r) for r in rows)


@dataclass(frozen=True)
class _Raw:
    """A section that keeps its mapping, for the views that emit it as the file has it."""

    _raw: Any = field(default=None, repr=False, compare=False, kw_only=True)

    def to_dict(self) -> Any:
        """The section's mapping as in the file (a deep copy).

        Returns
        -------
        dict or None
            The mapping (None for a section the document does not have).
        """
        return copy.deepcopy(self._raw)


@dataclass(frozen=True)
class SampleRate(_Raw):
    """``sample_rate_hz``.

    Attributes
    ----------
    value_hz : float
        The runtime's sample rate f_s [Hz].
    unit : str
        Its unit as the file states it (``Hz``).
    """

    value_hz: float
    unit: str = "Hz"


@dataclass(frozen=True)
class Delay(_Raw):
    """``delay_s``: the total measured-to-applied latency the controller was designed and certified for.

    Attributes
    ----------
    value_s : float
        The delay T [s].
    unit : str
        Its unit as the file states it (``s``).
    samples : float or None
        T·f_s [samples] as the file states it (may be fractional; None when absent).
    note : str or None
        The file's note.
    """

    value_s: float
    unit: str = "s"
    samples: float | None = None
    note: str | None = None


class _Quantities:
    """A section of named ``{value, unit}`` quantities (:data:`_KEYS`, the first fields) and their
    ``units``."""

    _KEYS: ClassVar[tuple[str, ...]] = ()
    units: Mapping[str, str]

    @classmethod
    def from_dict(cls, d: Mapping):
        """The section from its mapping (``{name: {value, unit}}``).

        Parameters
        ----------
        d : Mapping
            The section's mapping.

        Returns
        -------
        PlantSection or DesignSection or SixGains
            The typed section.
        """
        return cls(*(_value(d[k]) for k in cls._KEYS), units=_units(d), **cls._others(d))

    @classmethod
    def _others(cls, d: Mapping) -> dict:
        return {}

    def values(self) -> dict[str, float]:
        """The quantities by name, in the file's order.

        Returns
        -------
        dict
            name → value (units as the attributes).
        """
        return {k: getattr(self, k) for k in (self.units or self._KEYS)}


@dataclass(frozen=True)
class PlantSection(_Quantities):
    """``plant`` (or a gain-schedule entry's): the joint-reflected plant of the controller.

    Attributes
    ----------
    motor_inertia : float
        J_m [kg·m²].
    motor_damping : float
        B_m [N·m·s/rad].
    sea_stiffness : float
        K_s [N·m/rad].
    joint_inertia : float
        J_j [kg·m²].
    cuff_stiffness : float
        K_c [N·m/rad].
    units : Mapping[str, str]
        Each parameter's unit as the file states it, in the file's order.
    """

    _KEYS: ClassVar[tuple[str, ...]] = ("motor_inertia", "motor_damping", "sea_stiffness", "joint_inertia",
                                        "cuff_stiffness")
    motor_inertia: float
    motor_damping: float
    sea_stiffness: float
    joint_inertia: float
    cuff_stiffness: float
    units: Mapping[str, str] = field(default_factory=dict, repr=False)

    def to_plant(self):
        """The plant as :class:`exotune.model.plant.Plant`.

        Returns
        -------
        Plant
            J_m [kg·m²], B_m [N·m·s/rad], K_s [N·m/rad], J_j [kg·m²], K_c [N·m/rad].
        """
        from ..model.plant import Plant

        return Plant(self.motor_inertia, self.motor_damping, self.sea_stiffness, self.joint_inertia, self.cuff_stiffness)


@dataclass(frozen=True)
class DesignSection(_Quantities):
    """``design``: the double-compliance-shaping design the controller was built from (paper §IV).

    Attributes
    ----------
    amplification : float
        α [–].
    felt_inertia : float
        Ĵ_m/α, the inertia the human feels [kg·m²].
    felt_damping : float
        B̂_m/α, the damping the human feels [N·m·s/rad].
    zeta : float
        ζ [–].
    zeta_hat : float
        ζ̂ [–].
    units : Mapping[str, str]
        Each parameter's unit as the file states it, in the file's order.
    """

    _KEYS: ClassVar[tuple[str, ...]] = ("amplification", "felt_inertia", "felt_damping", "zeta", "zeta_hat")
    amplification: float
    felt_inertia: float
    felt_damping: float
    zeta: float
    zeta_hat: float
    units: Mapping[str, str] = field(default_factory=dict, repr=False)


@dataclass(frozen=True)
class SixGains(_Quantities):
    """``gains`` (or a gain-schedule entry's): the six gains of double compliance shaping, a
    descriptive summary (the runtime executes ``controller``), torque units.

    Attributes
    ----------
    K1 : float
        [N·m/rad].
    B1 : float
        [N·m·s/rad].
    K2 : float
        [–].
    B2 : float
        [s].
    K2_hat : float
        [–].
    B2_hat : float
        [s].
    units : Mapping[str, str]
        Each gain's unit as the file states it.
    convention : str or None
        The file's note on the torque units.
    """

    _KEYS: ClassVar[tuple[str, ...]] = ("K1", "B1", "K2", "B2", "K2_hat", "B2_hat")
    K1: float
    B1: float
    K2: float
    B2: float
    K2_hat: float
    B2_hat: float
    units: Mapping[str, str] = field(default_factory=dict, repr=False)
    convention: str | None = None

    @classmethod
    def _others(cls, d: Mapping) -> dict:
        return {"convention": d.get("convention")}


@dataclass(frozen=True)
class Filter:
    """One dynamic block of a controller (``controller.filters[]``).

    Attributes
    ----------
    name : str
        ``cuff_path``, ``dob_motor``, ….
    input : str
        The signal it acts on (``theta_m``, …, or ``tau_cmd``).
    sos : tuple of tuple of float
        Second-order sections, rows (b0, b1, b2, a0, a1, a2), a0 = 1, DF-II transposed.
    input_unit, output_unit, unit : str
        Units of its input, its output (N·m) and its gain.
    discretization : str
        ``tustin``.
    description : str or None
        Text.
    prewarp_hz : float or None
        Prewarp frequency [Hz].
    continuous : Mapping or None
        The continuous block it came from (``num``, ``den``, ``order``).
    """

    name: str
    input: str
    sos: tuple[tuple[float, ...], ...]
    input_unit: str = ""
    output_unit: str = ""
    unit: str = ""
    discretization: str = ""
    description: str | None = None
    prewarp_hz: float | None = None
    continuous: Mapping[str, Any] | None = field(default=None, repr=False)

    @classmethod
    def from_dict(cls, f: Mapping) -> "Filter":
        """The block from its mapping.

        Parameters
        ----------
        f : Mapping
            One entry of ``filters``.

        Returns
        -------
        Filter
            The typed block.
        """
        return cls(f["name"], f["input"], _rows(f["sos"]), f.get("input_unit", ""), f.get("output_unit", ""),
                   f.get("unit", ""), f.get("discretization", ""), f.get("description"), f.get("prewarp_hz"),
                   f.get("continuous"))


@dataclass(frozen=True)
class RealizationFilter:
    """One filter of a float32 realization.

    Attributes
    ----------
    name : str
        The filter's name.
    input : str
        The signal it acts on.
    sections : tuple of tuple of float
        Rows (β0, β1, β2, α1, α2) in the delta form δ = z − 1 (float32 values).
    """

    name: str
    input: str
    sections: tuple[tuple[float, ...], ...]


@dataclass(frozen=True)
class Realization:
    """``controller.realization``: what a float32 target executes (docs/controller-file.md#precision).

    Attributes
    ----------
    precision : str
        ``float32``.
    form : str
        ``delta_df2t``.
    gains : Mapping[str, float]
        signal → static gain rounded to float32, in the file's order.
    filters : tuple of RealizationFilter
        The filters in δ form.
    loop_divisor : float
        fl32(1 − g), g = Σ Π β0 over the filters on τ_cmd [–].
    note : str or None
        Text.
    """

    precision: str
    form: str
    gains: Mapping[str, float]
    filters: tuple[RealizationFilter, ...]
    loop_divisor: float
    note: str | None = field(default=None, compare=False)

    @classmethod
    def from_dict(cls, r: Mapping) -> "Realization":
        """The realization from its mapping.

        Parameters
        ----------
        r : Mapping
            A ``realization`` mapping (of the file, or built by
            :func:`exotune.controllerfile.precision.realization`).

        Returns
        -------
        Realization
            The typed realization.
        """
        return cls(r["precision"], r["form"], dict(r["gains"]),
                   tuple(RealizationFilter(f["name"], f["input"], _rows(f["sections"])) for f in r["filters"]),
                   r["loop_divisor"], r.get("note"))

    @classmethod
    def of(cls, r) -> "Realization":
        """``r`` when typed, else built from its mapping.

        Parameters
        ----------
        r : Realization or Mapping
            A realization.

        Returns
        -------
        Realization
            The typed realization.
        """
        return r if isinstance(r, cls) else cls.from_dict(r)


@dataclass(frozen=True)
class Controller:
    """``controller`` (or the complete controller of a gain-schedule entry): what the runtime executes.

    Attributes
    ----------
    gains : Mapping[str, float]
        signal → static gain, in the file's order (θ_m: N·m/rad, θ̇_m: N·m·s/rad, τ_s: –, τ̇_s: s,
        τ_c: –; zero gains omitted).
    gain_units : Mapping[str, str]
        signal → the gain's unit as the file states it.
    filters : tuple of Filter
        The dynamic blocks, in the file's order.
    realization : Realization or None
        The float32 realization (float32 files only).
    equation : str or None
        The runtime equation in words.
    """

    gains: Mapping[str, float]
    filters: tuple[Filter, ...]
    gain_units: Mapping[str, str] = field(default_factory=dict, repr=False)
    realization: Realization | None = None
    equation: str | None = field(default=None, repr=False)

    @classmethod
    def from_dict(cls, c: Mapping) -> "Controller":
        """The controller from its mapping.

        Parameters
        ----------
        c : Mapping
            A ``controller`` mapping (``gains``, ``filters``, optional ``realization``, ``equation``).

        Returns
        -------
        Controller
            The typed controller.
        """
        real = c.get("realization")
        return cls({s: g["gain"] for s, g in c["gains"].items()}, tuple(Filter.from_dict(f) for f in c["filters"]),
                   _units(c["gains"]), None if real is None else Realization.from_dict(real), c.get("equation"))

    @classmethod
    def of(cls, c) -> "Controller":
        """``c`` when typed, else built from its mapping.

        Parameters
        ----------
        c : Controller or Mapping
            A controller.

        Returns
        -------
        Controller
            The typed controller.
        """
        return c if isinstance(c, cls) else cls.from_dict(c)

    def gain(self, signal: str) -> float:
        """The static gain on ``signal`` (0.0 when the file omits it).

        Parameters
        ----------
        signal : str
            ``theta_m``, ``omega_m``, ``tau_s``, ``dtau_s`` or ``tau_c``.

        Returns
        -------
        float
            The gain (units in :attr:`gains`).
        """
        return self.gains.get(signal, 0.0)


@dataclass(frozen=True)
class Dob:
    """``dob``: the disturbance observer's summary. Checked by
    :func:`~exotune.controllerfile.checks.check_controller_file` (the schema leaves it open), so a
    field may hold anything until then.

    Attributes
    ----------
    q_cutoff_hz : float
        The Q filter's cutoff [Hz].
    q_cutoff_unit : str
        Its unit as the file states it.
    q_damping : float
        The Q filter's damping [–].
    q_damping_unit : str
        Its unit as the file states it (``1``).
    filters : tuple of str
        The names of the DOB's filters.
    """

    q_cutoff_hz: Any = None
    q_cutoff_unit: Any = None
    q_damping: Any = None
    q_damping_unit: Any = None
    filters: Any = None

    @classmethod
    def from_dict(cls, d: Mapping) -> "Dob":
        """The section from its (unchecked) mapping.

        Parameters
        ----------
        d : Mapping
            The ``dob`` mapping.

        Returns
        -------
        Dob
            The section; a quantity that is not a mapping has value and unit None.
        """
        q, z = d.get("q_cutoff_hz"), d.get("q_damping")
        q, z = (q if isinstance(q, Mapping) else {}), (z if isinstance(z, Mapping) else {})
        listed = d.get("filters")
        return cls(q.get("value"), q.get("unit"), z.get("value"), z.get("unit"),
                   tuple(listed) if isinstance(listed, list) else listed)


@dataclass(frozen=True)
class ScheduleEntry(_Raw):
    """One ``gain_schedule.entries[]``: a complete controller frozen at one joint angle.

    Attributes
    ----------
    joint_angle_rad : float
        The joint angle [rad].
    ratio : float
        The transmission ratio there [–].
    plant : PlantSection
        The reflected plant.
    gains : SixGains
        The six gains recomputed there.
    controller : Controller
        Its own controller section (gains, filters, realization);
        :meth:`ControllerFile.entry_view` gives the complete controller it runs.
    predicted_sampled : Mapping or None
        Its predicted sampled-data analysis (untrusted: certify compares it).
    golden_tau_cmd : tuple of float
        Its golden outputs [N·m] for the common golden inputs.
    golden_tau_cmd_unit : str
        Their unit as the file states it.
    """

    joint_angle_rad: float
    ratio: float
    plant: PlantSection
    gains: SixGains
    controller: Controller
    predicted_sampled: Any = field(default=None, repr=False)
    golden_tau_cmd: tuple[float, ...] = field(default=(), repr=False)
    golden_tau_cmd_unit: str | None = None


def nearest_index(angles: list[float], joint_angle_rad: float) -> int:
    """Index of the gain-schedule angle nearest ``joint_angle_rad`` [rad], the first of two equally
    near; an angle beyond the table is first clamped to it (the end entry, even where the
    distances round to a tie). The one look-up of the reference runtime and the C port
    (``exotune_controller_for_angle``).

    Parameters
    ----------
    angles : list of float
        The entries' joint angles [rad].
    joint_angle_rad : float
        A finite joint angle [rad].

    Returns
    -------
    int
        The index into ``angles``.

    Examples
    --------
    >>> nearest_index([0.0, 1.0, 2.0], 0.5), nearest_index([0.0, 1.0, 2.0], 1e308), nearest_index([0.0, 2.0], -1e308)
    (0, 2, 0)
    """
    a = min(max(joint_angle_rad, min(angles)), max(angles))
    return min(range(len(angles)), key=lambda i: abs(angles[i] - a))


@dataclass(frozen=True)
class GainSchedule:
    """``gain_schedule``.

    Attributes
    ----------
    entries : tuple of ScheduleEntry
        One per joint angle of the transmission table.
    variable : str
        ``joint_angle_rad``.
    unit : str
        ``rad``.
    """

    entries: tuple[ScheduleEntry, ...]
    variable: str = "joint_angle_rad"
    unit: str = "rad"

    def nearest(self, joint_angle_rad: float) -> ScheduleEntry:
        """The entry nearest ``joint_angle_rad`` (the first of two equally near); an angle beyond
        the schedule's angles is first clamped to them, so that it runs the end entry even where
        the distances round to a tie (1e308 rad: |1e308 − 0| = |1e308 − 2| in floating point).

        Parameters
        ----------
        joint_angle_rad : float
            The joint angle [rad].

        Returns
        -------
        ScheduleEntry
            The entry the runtime runs there.
        """
        return self.entries[nearest_index([e.joint_angle_rad for e in self.entries], joint_angle_rad)]


@dataclass(frozen=True)
class Transmission:
    """``transmission``: the design file's transmission table.

    Attributes
    ----------
    joint_angle_rad : tuple of float
        Joint angles [rad].
    ratio : tuple of float
        The transmission ratio at each [–].
    """

    joint_angle_rad: tuple[float, ...]
    ratio: tuple[float, ...]


@dataclass(frozen=True)
class CertifySection:
    """``certify``: the families ``certify`` checks, in design-file form (parsed by
    :func:`exotune.config.parse_human` and :func:`exotune.config.parse_env`).

    Attributes
    ----------
    humans : tuple of Mapping
        The human families.
    environment : tuple of Mapping
        The environment ranges.
    """

    humans: tuple[Mapping[str, Any], ...] = ()
    environment: tuple[Mapping[str, Any], ...] = ()


@dataclass(frozen=True)
class Requirements(_Raw):
    """``requirements``: what the file must keep (user intent, not a prediction).

    Attributes
    ----------
    latency_margin_s : float
        The extra delay [s] the file must tolerate (0: no requirement).
    unit : str
        ``s``.
    source : str or None
        Where the requirement came from.
    """

    latency_margin_s: float
    unit: str = "s"
    source: str | None = None


@dataclass(frozen=True)
class Predicted:
    """``predicted``: the design-time predictions (informational; untrusted, anything malformed
    is a mismatch for ``certify``, never an error).

    Attributes
    ----------
    continuous : Mapping or None
        The continuous analysis.
    latency_margin : Mapping or None
        The continuous latency margin (``extra_delay_s`` [s], ``critical``, …).
    sampled : Mapping or None
        The sampled-data analysis of this file.
    sampled_latency_margin : Mapping or None
        Its sampled-data latency margin.
    """

    continuous: Any = None
    latency_margin: Any = None
    sampled: Any = None
    sampled_latency_margin: Any = None


@dataclass(frozen=True)
class Golden:
    """``golden``: the reference runtime's outputs for fixed inputs, from the zero state.

    Attributes
    ----------
    inputs : Mapping[str, tuple of float]
        signal → its samples (θ_m [rad], θ̇_m [rad/s], τ_s [N·m], τ̇_s [N·m/s], τ_c [N·m]), in the
        file's order.
    input_units : Mapping[str, str]
        signal → its unit as the file states it.
    tau_cmd : tuple of float
        The commands [N·m].
    tau_cmd_unit : str or None
        Their unit as the file states it.
    note : str or None
        Text.
    """

    inputs: Mapping[str, tuple[float, ...]] = field(default_factory=dict, repr=False)
    input_units: Mapping[str, str] = field(default_factory=dict, repr=False)
    tau_cmd: tuple[float, ...] = field(default=(), repr=False)
    tau_cmd_unit: str | None = None
    note: str | None = None


@dataclass(frozen=True)
class Provenance(_Raw):
    """``provenance``: where the file came from.

    Attributes
    ----------
    exotune_version : str or None
        The exotune that wrote it.
    source : str or None
        The design file's name (no directories).
    input_sha256 : str or None
        The design file's sha256.
    created_utc : str or None
        ISO 8601.
    hand_tuned : Any
        ``true`` for a controller edited by hand (any other value than true/false is refused by
        :func:`exotune.controllerfile.certify.hand_tuned`).
    uncertified : tuple of str
        Why certify would refuse it (export with ``--allow-uncertified``).
    allow_uncertified : bool
        Written with ``--allow-uncertified``.
    """

    exotune_version: str | None = None
    source: str | None = None
    input_sha256: str | None = None
    created_utc: str | None = None
    hand_tuned: Any = False
    uncertified: tuple[str, ...] = ()
    allow_uncertified: bool = False


@dataclass(frozen=True)
class Implementation:
    """``implementation``: the design file's implementation section as exported (design-file
    form, units in the key names; parsed and validated by :func:`exotune.config.design_from_mapping`).

    Attributes
    ----------
    mapping : Mapping
        The section as in the file.
    delay_s : Any
        Its delay [s] (unvalidated: compared with the file's :attr:`ControllerFile.delay_s`).
    sample_rate_hz : Any
        Its sample rate [Hz] (unvalidated).
    precision : Any
        ``float64``, ``float32`` or None (unvalidated:
        :func:`exotune.controllerfile.precision.precision_of`).
    """

    mapping: Mapping[str, Any] = field(repr=False)
    delay_s: Any = None
    sample_rate_hz: Any = None
    precision: Any = None


@dataclass(frozen=True)
class ControllerFile:
    """A validated controller file (schema ``exotune.controller/1``, docs/controller-file.md), typed.

    Built by :meth:`from_dict` only; :meth:`to_dict` gives the mapping back unchanged (writing it
    with :func:`~exotune.controllerfile.fileio.write_controller` reproduces the file byte for byte).

    Attributes
    ----------
    schema : str
        ``exotune.controller/1``.
    sample_rate : SampleRate
        f_s [Hz] (also :attr:`sample_rate_hz`).
    delay : Delay
        The total latency T [s] (also :attr:`delay_s`).
    plant : PlantSection
        The plant.
    design : DesignSection
        The design the controller was built from.
    gains : SixGains
        The six-gain summary.
    controller : Controller
        What the runtime executes.
    certify : CertifySection
        The families ``certify`` checks.
    signals : Mapping
        ``inputs`` (signal → unit) and ``output`` (``tau_cmd`` → N·m).
    implementation : Implementation or None
        The design's implementation section (None in files written before 0.7.0).
    dob : Dob or None
        The DOB's summary (None without a DOB).
    gain_schedule : GainSchedule or None
        The schedule (None without a transmission).
    gain_schedule_note : str or None
        Text.
    transmission : Transmission or None
        The transmission table (None without one).
    requirements : Requirements or None
        The latency margin the file must keep (None in older files).
    predicted : Predicted
        The design-time predictions.
    golden : Golden
        The golden vectors.
    provenance : Provenance
        Where the file came from.
    """

    schema: str
    sample_rate: SampleRate
    delay: Delay
    plant: PlantSection
    design: DesignSection
    gains: SixGains
    controller: Controller
    certify: CertifySection
    signals: Mapping[str, Any] = field(default_factory=dict, repr=False)
    implementation: Implementation | None = None
    dob: Dob | None = None
    gain_schedule: GainSchedule | None = None
    gain_schedule_note: str | None = field(default=None, repr=False)
    transmission: Transmission | None = None
    requirements: Requirements | None = None
    predicted: Predicted = field(default_factory=Predicted, repr=False)
    golden: Golden = field(default_factory=Golden, repr=False)
    provenance: Provenance = field(default_factory=Provenance)
    _doc: Mapping[str, Any] = field(default_factory=dict, repr=False, compare=False)

    @classmethod
    def from_dict(cls, doc: Mapping) -> "ControllerFile":
        """The one builder of the model: from a controller file's mapping that passed the schema
        (:func:`~exotune.controllerfile.schema.validate_controller`), or from a document ``export``
        is building. The mapping is deep-copied: changing it later changes nothing here.

        Parameters
        ----------
        doc : Mapping
            The controller file's mapping.

        Returns
        -------
        ControllerFile
            The typed file.

        References
        ----------
        docs/controller-file.md (the fields).
        """
        d = copy.deepcopy(dict(doc))
        return cls(d["schema"], SampleRate(_value(d["sample_rate_hz"]), d["sample_rate_hz"]["unit"], _raw=d["sample_rate_hz"]),
                   _delay(d["delay_s"]), PlantSection.from_dict(d["plant"]), DesignSection.from_dict(d["design"]),
                   SixGains.from_dict(d["gains"]), Controller.from_dict(d["controller"]), _certify(d["certify"]),
                   d.get("signals") or {}, _implementation(d.get("implementation")),
                   None if d.get("dob") is None else Dob.from_dict(d["dob"]), _schedule(d), d.get("gain_schedule_note"),
                   _transmission(d.get("transmission")), _requirements(d.get("requirements")),
                   _predicted(d.get("predicted")), _golden(d.get("golden")), _provenance(d.get("provenance")), d)

    def to_dict(self) -> dict:
        """The file's mapping, as validated (a deep copy): for writing the file back and for the
        views that emit or hash the exact mapping.

        Returns
        -------
        dict
            The mapping.
        """
        return copy.deepcopy(dict(self._doc))

    @property
    def sample_rate_hz(self) -> float:
        """f_s [Hz]."""
        return self.sample_rate.value_hz

    @property
    def delay_s(self) -> float:
        """The total latency T [s]."""
        return self.delay.value_s

    @property
    def schedule_entries(self) -> tuple[ScheduleEntry, ...]:
        """The gain-schedule entries (empty without a schedule)."""
        return () if self.gain_schedule is None else self.gain_schedule.entries

    def entry_view(self, entry: ScheduleEntry) -> "ControllerFile":
        """The file as seen by one gain-schedule entry: its plant, six gains and controller in place
        of the top-level ones (:func:`~exotune.controllerfile.fileio.schedule_entry_doc`).

        Parameters
        ----------
        entry : ScheduleEntry
            One of :attr:`schedule_entries`.

        Returns
        -------
        ControllerFile
            The view (its :meth:`to_dict` is the entry's view of the mapping).
        """
        r, d = entry._raw, self._doc
        doc = {**d, "plant": r["plant"], "gains": r["gains"], "controller": {**d["controller"], **r["controller"]}}
        return replace(self, plant=entry.plant, gains=entry.gains, controller=Controller.from_dict(doc["controller"]),
                       _doc=doc)

    def with_delay(self, delay_s: float) -> "ControllerFile":
        """The file with another total delay (and its samples at the file's rate).

        Parameters
        ----------
        delay_s : float
            The delay T [s].

        Returns
        -------
        ControllerFile
            The changed copy.
        """
        raw = {**self._doc["delay_s"], "value": delay_s, "samples": delay_s * self.sample_rate_hz}
        return replace(self, delay=_delay(raw), _doc={**self._doc, "delay_s": raw})


    def without_dob(self) -> "ControllerFile":
        """The file without its disturbance observer (``simulate``'s comparison run): the DOB's
        filters (those ``dob.filters`` names, and every ``dob_*``) removed from the nominal
        controller, ``dob`` null.

        Returns
        -------
        ControllerFile
            The changed copy.
        """
        d = copy.deepcopy(dict(self._doc))
        names = set((self.dob.filters if self.dob is not None else None) or [])
        d["controller"]["filters"] = [f for f in d["controller"]["filters"]
                                      if f["name"] not in names and not f["name"].startswith("dob_")]
        d["dob"] = None
        return ControllerFile.from_dict(d)


def as_controller_file(doc) -> ControllerFile:
    """``doc`` as a :class:`ControllerFile`: itself when it is one, else built from the mapping
    (:meth:`ControllerFile.from_dict`). The entry point of the functions that accept either.

    Parameters
    ----------
    doc : ControllerFile or Mapping
        A controller file.

    Returns
    -------
    ControllerFile
        The typed file.
    """
    return doc if isinstance(doc, ControllerFile) else ControllerFile.from_dict(doc)


def _delay(d: Mapping) -> Delay:
    return Delay(_value(d), d["unit"], d.get("samples"), d.get("note"), _raw=d)


def _certify(d: Mapping) -> CertifySection:
    return CertifySection(tuple(d.get("humans") or ()), tuple(d.get("environment") or ()))


def _implementation(d) -> Implementation | None:
    if d is None:
        return None
    return Implementation(d, d.get("delay_s"), d.get("sample_rate_hz"), d.get("precision"))


def _schedule(doc: Mapping) -> GainSchedule | None:
    s = doc.get("gain_schedule")
    if s is None:
        return None
    entries = []
    for e in s["entries"]:
        g = e.get("golden_tau_cmd") or {}
        entries.append(ScheduleEntry(e["joint_angle_rad"], e["ratio"], PlantSection.from_dict(e["plant"]),
                                     SixGains.from_dict(e["gains"]),
                                     Controller.from_dict(e["controller"]),
                                     e.get("predicted_sampled"), tuple(g.get("values") or ()), g.get("unit"), _raw=e))
    return GainSchedule(tuple(entries), s.get("variable", "joint_angle_rad"), s.get("unit", "rad"))


def _transmission(d) -> Transmission | None:
    return None if d is None else Transmission(tuple(d["joint_angle_rad"]), tuple(d["ratio"]))


def _requirements(d) -> Requirements | None:
    return None if d is None else Requirements(d["latency_margin_s"], d.get("unit", "s"), d.get("source"), _raw=d)


def _predicted(d) -> Predicted:
    d = d or {}
    return Predicted(d.get("continuous"), d.get("latency_margin"), d.get("sampled"), d.get("sampled_latency_margin"))


def _golden(d) -> Golden:
    if d is None:
        return Golden()
    ins = d["inputs"]
    return Golden({s: tuple(v["values"]) for s, v in ins.items()}, _units(ins), tuple(d["tau_cmd"]["values"]),
                  d["tau_cmd"]["unit"], d.get("note"))


def _provenance(d) -> Provenance:
    if d is None:
        return Provenance()
    return Provenance(d.get("exotune_version"), d.get("source"), d.get("input_sha256"), d.get("created_utc"),
                      d.get("hand_tuned", False), tuple(d.get("uncertified") or ()), bool(d.get("allow_uncertified")),
                      _raw=d)
