"""Configuration of a CAN input (`[inputs.<bus>]`, `type = "can"`).

Everything that can be checked before start-up is checked here, so that a wrong DBC
path or a DBC that lacks a mapped signal stops edged with a message naming the key
(DESIGN §8), not with a decoder that silently emits nothing at sea.
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, field_validator

from edged.config import MAX_WATCHDOG, KindName, ReconnectSettings, SourceName, valid_name
from edged.plugin import InputConfig
from edged.records import KINDS

from .reference import reference_dbc_path, reference_signals

if TYPE_CHECKING:  # cantools is imported when a DBC is loaded: not by every `edged` command
    from cantools.database.can import Database


class SignalMap(BaseModel):
    """How one DBC message becomes one measurement kind."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    #: DBC message name.
    message: str
    #: Measurement kind (DESIGN §2).
    kind: KindName
    #: Kind field -> DBC signal name.
    fields: dict[str, str]
    #: Value of the `mark` field (draft kind): which draft mark this message is.
    mark: str | None = None
    #: Source of the measurements; `{bus}` and `{message}` are filled in.
    source: str = "{bus}.{message}"
    #: Signal counting +1 per frame (8-bit wrap): gaps are counted as lost frames.
    counter: str | None = None

    @field_validator("source")
    @classmethod
    def _source(cls, v: str) -> str:
        try:
            example = v.format(bus="b", message="m")
        except (KeyError, IndexError, ValueError) as exc:
            raise ValueError(f"only {{bus}} and {{message}} may be filled in ({exc})") from None
        valid_name(example)  # the source is a Zenoh key segment: no '/', no spaces
        return v


class CanConfig(InputConfig, ReconnectSettings):
    """One CAN bus: transport, DBC, signal mappings, NMEA 2000 source names, recovery.

    It claims no resource (`claims`): SocketCAN and python-can's virtual bus give every
    frame to every socket open on the channel, so two inputs on one bus take nothing
    from each other; each decodes all of it under its own source names (for instance
    a second input with a site DBC for proprietary frames).
    """

    #: python-can interface: SocketCAN on board, `virtual` for tests and the demo.
    interface: Literal["socketcan", "virtual"] = "socketcan"
    #: SocketCAN interface (`can0`) or the virtual bus's channel name.
    channel: str = "can0"
    #: Bits per second (CAN FD data phases reach a few Mbit/s).
    bitrate: int = Field(250_000, gt=0, le=16_000_000)
    #: Site DBC; relative paths are relative to the configuration file. Default: the
    #: reference DBC of DESIGN §5.
    dbc: Path | None = Field(None, validate_default=True)
    #: DBC message -> measurement mappings; default: those of the reference DBC.
    signals: tuple[SignalMap, ...] = Field(
        default_factory=lambda: tuple(SignalMap(**s) for s in reference_signals()),
        validate_default=True,
    )
    #: NMEA 2000 source address -> source name.
    source_names: dict[int, SourceName] = Field(default_factory=dict)
    #: NMEA 2000 ISO NAME (64-bit, hex as in `0xc0788c00e7e04312`) -> source name;
    #: follows the device when its address changes (address claims, PGN 60928).
    iso_names: dict[str, SourceName] = Field(default_factory=dict)
    #: Magnetic variation (degrees, east +) when no PGN gives one.
    magnetic_variation_deg: float | None = Field(None, ge=-180.0, le=180.0)
    #: Seconds without any frame before the bus is closed and reopened.
    watchdog: float = Field(10.0, gt=0, le=MAX_WATCHDOG)

    @field_validator("dbc")
    @classmethod
    def _dbc(cls, v: Path | None, info: ValidationInfo) -> Path:
        if v is None:
            return reference_dbc_path()
        if not v.is_absolute():
            base = (info.context or {}).get("config_dir") or Path.cwd()
            v = Path(base) / v
        _load_dbc(v)
        return v

    @field_validator("signals")
    @classmethod
    def _signals(cls, v: tuple[SignalMap, ...], info: ValidationInfo) -> tuple[SignalMap, ...]:
        path = info.data.get("dbc")
        if path is None:  # the DBC itself was wrong: that error is reported on `dbc`
            return v
        db = _load_dbc(path)
        for i, sm in enumerate(v):
            _check_mapping(db, sm, f"signals[{i}]")
        return v

    @field_validator("source_names")
    @classmethod
    def _addresses(cls, v: dict[int, str]) -> dict[int, str]:
        for addr in v:
            if not 0 <= addr <= 253:
                raise ValueError(f"address {addr} outside 0..253")
        return v

    @field_validator("iso_names")
    @classmethod
    def _iso_names(cls, v: dict[str, str]) -> dict[str, str]:
        for key in v:
            _parse_iso_name(key)
        return v

    @functools.cached_property
    def database(self) -> Database:
        """The loaded DBC (loaded once per configuration object)."""
        assert self.dbc is not None  # the validator fills in the default
        return _load_dbc(self.dbc)

    def iso_name_map(self) -> dict[int, str]:
        return {_parse_iso_name(k): name for k, name in self.iso_names.items()}


def default_config() -> CanConfig:
    """The configuration `edged replay` uses for a CAN bus it has no section for."""
    return CanConfig(type="can")


def _load_dbc(path: Path) -> Database:
    if not path.is_file():
        raise ValueError(f"DBC file {str(path)!r} not found")
    import cantools  # here, not at the top: see the TYPE_CHECKING import

    try:
        return cantools.database.load_file(path, database_format="dbc", strict=True)
    except Exception as exc:  # cantools raises parser-specific types; all mean "bad DBC"
        raise ValueError(f"DBC file {str(path)!r} cannot be read: {exc}") from None


def _check_mapping(db: Database, sm: SignalMap, where: str) -> None:
    """Raise ValueError naming the key when a mapping does not fit the DBC or the kind."""
    try:
        msg = db.get_message_by_name(sm.message)
    except KeyError:
        raise ValueError(f"{where}.message: the DBC has no message {sm.message!r}") from None
    names = {s.name for s in msg.signals}
    spec = KINDS[sm.kind]
    for field, signal in sm.fields.items():
        if field not in spec.field_names:
            raise ValueError(f"{where}.fields.{field}: kind {sm.kind!r} has no field {field!r}")
        if signal not in names:
            raise ValueError(
                f"{where}.fields.{field}: DBC message {sm.message!r} has no signal {signal!r}"
            )
    has_mark = "mark" in spec.field_names
    if sm.mark is not None and not has_mark:
        raise ValueError(f"{where}.mark: kind {sm.kind!r} has no mark")
    given = set(sm.fields) | ({"mark"} if sm.mark is not None else set())
    for f in spec.fields:
        if f.required and f.name not in given:
            raise ValueError(f"{where}.fields: required field {f.name!r} of kind {sm.kind!r} is not mapped")
    if sm.counter is not None and sm.counter not in names:
        raise ValueError(f"{where}.counter: DBC message {sm.message!r} has no signal {sm.counter!r}")


def _parse_iso_name(key: Any) -> int:
    try:
        n = int(str(key), 16)
    except ValueError:
        raise ValueError(f"ISO NAME {key!r} is not a hexadecimal number") from None
    if not 0 <= n < 1 << 64:
        raise ValueError(f"ISO NAME {key!r} is not a 64-bit value")
    return n
