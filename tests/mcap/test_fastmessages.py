"""The recorder's fast message path writes exactly what `Writer.add_message` writes."""

from __future__ import annotations

import io
import random

from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from edged_mcap.fastmessages import FastMessages


def _write(fast: bool, messages: list[tuple[int, int, bytes, int]], flush_every: int) -> bytes:
    out = io.BytesIO()
    w = Writer(out, chunk_size=2048, compression=CompressionType.ZSTD)
    w.start(profile="", library="test")
    sid = w.register_schema("s", "jsonschema", b"{}")
    channels = [w.register_channel(f"/c{i}", "json", sid) for i in range(3)]
    fm = FastMessages.attach(w) if fast else None
    add = fm.add if fm is not None else w.add_message
    for i, (ch, log, data, pub) in enumerate(messages):
        add(channels[ch], log, data, pub)
        if (i + 1) % flush_every == 0:
            w.flush()
    w.finish()
    return out.getvalue()


def test_same_bytes_as_add_message_across_chunks_flushes_and_out_of_order_times():
    rnd = random.Random(7)
    t0 = 1_732_350_000_000_000_000
    messages = []
    for i in range(3000):
        # Mostly increasing, sometimes a little older (merged inputs are not perfectly ordered).
        log = t0 + i * 10_000_000 - (rnd.randrange(50_000_000) if i % 17 == 0 else 0)
        messages.append((rnd.randrange(3), log, rnd.randbytes(rnd.randrange(1, 300)), t0 + i))
    messages[10] = (1, t0 - 1_000_000_000, b"{}", t0)  # older than the file's first message
    assert FastMessages.attach(Writer(io.BytesIO())) is not None, (
        "the installed mcap Writer's internals changed: update edged_mcap.fastmessages"
    )
    fast = _write(True, messages, flush_every=700)
    assert fast == _write(False, messages, flush_every=700)
    back = [(m.log_time, m.data) for _, _, m in make_reader(io.BytesIO(fast)).iter_messages(log_time_order=False)]
    assert back == [(log, data) for _, log, data, _ in messages]


def test_a_writer_without_chunks_is_left_to_add_message():
    assert FastMessages.attach(Writer(io.BytesIO(), use_chunking=False)) is None
