"""Raw records out of a recording, for `edged replay FILE.mcap`.

Only the raw channels are read back: the core decodes them again with the inputs'
decoders, so new tuning can be tried on old voyages. Unfinished files are read up to
their last complete chunk; what could not be read is counted, never raised.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import BinaryIO, Iterator

from mcap.exceptions import McapError

from edged.health import ComponentHealth
from edged.records import RawRecord
from edged.logformats import UnknownFormat
from edged.timecheck import BAD_TIME, DEFAULT_LIMITS, TimeLimits, TimeWindow

from edged.channels import RAW_PREFIX, NotRaw, raw_from_message
from .reading import NoRecords, ReadReport, iter_messages

__all__ = ["read_raw"]


def read_raw(
    stream: BinaryIO, health: ComponentHealth, name: str | Path, limits: TimeLimits = DEFAULT_LIMITS
) -> Iterator[RawRecord]:
    """RawRecords of every `/raw/...` channel in file order; rejects are counted.

    A record's `t` that is not finite, negative or after the limits' `latest`
    (edged.timecheck; from 0 on, since a recording may hold untimed records stamped
    0.0, and without the one-day rule, since one recording may merge files days
    apart), such as `Infinity` or a time centuries ahead, is `rejected.bad_time`:
    the replay clock never jumps to it."""
    report = ReadReport()
    accept = TimeWindow(limits, earliest=0.0, ahead=float("inf")).accept
    bad_time_topics: set[str] = set()
    try:
        for channel, _schema, msg in iter_messages(stream, report):
            topic = channel.topic
            if not topic.startswith(RAW_PREFIX):
                continue
            try:
                payload = json.loads(msg.data)
            except (ValueError, RecursionError):  # UnicodeDecodeError is a ValueError; JSON nested too deep
                health.count("rejected.bad_json")
                health.error(f"{name}: {topic}: a message is not JSON")
                continue
            try:
                raw = raw_from_message(topic, payload)
            except NotRaw as exc:
                health.count("rejected.bad_raw")
                health.error(f"{name}: {topic}: not a raw record ({exc})")
                continue
            except OverflowError:  # "t": 1e999999 written as an integer: no float holds it
                health.count("rejected." + BAD_TIME)
                health.error(f"{name}: {topic}: a time too large for a float")
                continue
            if not accept(raw.t):
                health.count("rejected." + BAD_TIME)
                if topic not in bad_time_topics:  # logged once per channel
                    bad_time_topics.add(topic)
                    health.error(f"{name}: {topic}: time {raw.t!r} cannot be true (further ones counted)")
                continue
            yield raw
    except NoRecords as exc:  # the magic and nothing else: refused like an empty file
        raise UnknownFormat(f"no records: {name} {exc.reason}") from None
    except McapError as exc:
        health.count("rejected.not_mcap")
        health.error(f"{name}: {exc}")
        return
    _report(report, health, name)


def _report(report: ReadReport, health: ComponentHealth, name: str | Path) -> None:
    if report.bad_chunks:
        health.count("rejected.bad_chunk", report.bad_chunks)
        health.error(f"{name}: {report.bad_chunks} damaged chunk(s) skipped: {report.bad_chunk_errors[0]}")
    if report.orphans:
        health.count("rejected.no_channel", report.orphans)
    if report.bad_records:
        health.count("rejected.bad_record", report.bad_records)
        health.error(f"{name}: {report.bad_records} damaged record(s) skipped: {report.bad_record_errors[0]}")
    if report.truncated or report.error or not report.finished:
        # A length field that cannot be true is damage; a file that just stops is not.
        health.count("damaged" if (report.error or "").startswith("damaged") else "truncated")
        health.error(
            f"{name}: unfinished recording ({report.unfinished_why}): read {report.messages} messages "
            f"in {report.chunks} complete chunks; anything after them is lost"
        )
