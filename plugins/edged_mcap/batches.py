"""The recorder's write path: a batch of records into messages of the open file.

Every record of a replay passes here, so the loop keeps to plain local names (the
file's channel table, its message list) and converts a time to nanoseconds once for
the run of records that share it (the sentences of one GNSS epoch, a raw record and its
measurements). The batch's messages go to the file in one call (`McapFile.add_batch`)
and, before a new channel's first message, those collected so far (a new channel's
record goes where the file has got to, as one add at a time did).

A record that cannot be recorded is counted `rejected.<reason>` in health and the
loop goes on (`bad_time`, `unknown_record`, `malformed`, `unencodable`); a write that
fails is `WriteFailed`, saying which records it lost.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from edged.health import ComponentHealth

from edged.channels import MAX_T, dumps, encode, to_ns
from .mcapfile import McapFile

__all__ = ["DERIVED", "MAX_T", "Recorded", "WriteFailed", "record_batch"]

#: Topics of messages derived from a record recorded on its own channel as well (a
#: position's LocationFix): every other message is a record of its own.
DERIVED = "/location/"


class WriteFailed(Exception):
    """Adding a batch's messages failed (`error`): `added` of its messages reached the
    file's open chunk first, `first_lost` is the first record whose messages were lost,
    and `rejected` records had been rejected before."""

    def __init__(self, error: OSError, added: int, first_lost: int, rejected: int) -> None:
        super().__init__(str(error))
        self.error = error
        self.added = added
        self.first_lost = first_lost
        self.rejected = rejected


@dataclass(frozen=True)
class Recorded:
    """What a batch gave the file: messages added to its open chunk, and records
    settled without one (rejected, or their own message not encodable)."""

    added: int
    rejected: int


def _add(f: McapFile, msgs: list[tuple[int, int, bytes]], owner: list[int], pub: int, added: int, rejected: int) -> int:
    """Add the messages collected so far to the file and forget them; the batch's
    messages added in all. `owner[j]` is the record message j came from."""
    if not msgs:
        return added
    try:
        f.add_batch(msgs, pub)
    except OSError as exc:
        k = getattr(exc, "added", 0)
        raise WriteFailed(exc, added + k, owner[k] if k < len(owner) else owner[-1] + 1, rejected) from exc
    added += len(msgs)
    msgs.clear()
    owner.clear()
    return added


def _reject(health: ComponentHealth, reason: str, message: str) -> None:
    health.count(f"rejected.{reason}")
    health.error(message)


def record_batch(f: McapFile, batch: list[Any], pub: int, health: ComponentHealth) -> Recorded:
    """Add `batch`'s messages to `f` (published at `pub`, ns); `WriteFailed` when a
    write or a new channel fails."""
    channels = f.channels
    msgs: list[tuple[int, int, bytes]] = []
    owner: list[int] = []
    last_t: Any = None
    log = added = rejected = 0
    for i, rec in enumerate(batch):
        try:
            outs = encode(rec)
        except KeyError:
            _reject(health, "unknown_record", f"not a record edged knows: {type(rec).__name__}")
            rejected += 1
            continue
        except (AttributeError, TypeError, ValueError) as exc:  # e.g. raw data that is not bytes
            _reject(health, "malformed", f"malformed {type(rec).__name__}: {type(exc).__name__}: {exc}")
            rejected += 1
            continue
        t = getattr(rec, "t", None)
        if t != last_t or t.__class__ is not last_t.__class__:
            if not isinstance(t, (int, float)) or not 0.0 <= t < MAX_T:
                _reject(health, "bad_time", f"record time outside the MCAP range: {t!r} ({type(rec).__name__})")
                rejected += 1
                continue
            log = to_ns(t)
            last_t = t
        for topic, schema, payload in outs:
            try:
                data, cleaned = dumps(payload)
            except (TypeError, ValueError) as exc:
                _reject(health, "unencodable", f"{topic}: not JSON: {exc}")
                if not topic.startswith(DERIVED):
                    rejected += 1  # the record's own message is not recorded
                continue
            if cleaned:
                health.count("nonfinite_as_null")
            cid = channels.get(topic)
            if cid is None:
                added = _add(f, msgs, owner, pub, added, rejected)
                try:
                    cid = f.channel(topic, schema)
                except OSError as exc:  # nothing of this record on is in the file
                    raise WriteFailed(exc, added, i, rejected) from exc
            msgs.append((cid, log, data))
            owner.append(i)
    return Recorded(_add(f, msgs, owner, pub, added, rejected), rejected)
