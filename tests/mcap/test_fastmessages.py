"""The recorder's fast message path writes exactly what `Writer.add_message` writes."""

from __future__ import annotations

import io
import random

from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from edged_mcap.fastmessages import FastMessages


def _write_batches(messages: list[tuple[int, int, bytes, int]], sizes: list[int]) -> bytes:
    """The messages in batches of `sizes` through `add_batch` (each batch shares the
    publish time of its first message), flushing after each batch."""
    out = io.BytesIO()
    w = Writer(out, chunk_size=2048, compression=CompressionType.ZSTD)
    w.start(profile="", library="test")
    sid = w.register_schema("s", "jsonschema", b"{}")
    channels = [w.register_channel(f"/c{i}", "json", sid) for i in range(3)]
    fm = FastMessages.attach(w)
    i = 0
    for n in sizes:
        batch = messages[i : i + n]
        i += n
        if batch:
            assert fm.add_batch([(channels[ch], log, data) for ch, log, data, _ in batch], batch[0][3]) == len(batch)
        w.flush()
    w.finish()
    return out.getvalue()


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


def test_a_batch_writes_the_same_bytes_as_one_add_message_each():
    rnd = random.Random(11)
    t0 = 1_732_350_000_000_000_000
    messages = []
    sizes = [rnd.choice([0, 1, 2, 7, 50, 300]) for _ in range(40)]
    pubs = []
    for n in sizes:
        pub = t0 + len(messages)
        for _ in range(n):
            i = len(messages)
            log = t0 + i * 10_000_000 - (rnd.randrange(50_000_000) if i % 13 == 0 else 0)
            messages.append((rnd.randrange(3), log, rnd.randbytes(rnd.randrange(1, 600)), pub))
        pubs.append(pub)
    # one add_message per message, flushing where the batches end
    out = io.BytesIO()
    w = Writer(out, chunk_size=2048, compression=CompressionType.ZSTD)
    w.start(profile="", library="test")
    sid = w.register_schema("s", "jsonschema", b"{}")
    channels = [w.register_channel(f"/c{i}", "json", sid) for i in range(3)]
    i = 0
    for n in sizes:
        for ch, log, data, pub in messages[i : i + n]:
            w.add_message(channels[ch], log, data, pub)
        i += n
        w.flush()
    w.finish()
    assert _write_batches(messages, sizes) == out.getvalue()


def test_a_batch_whose_chunk_cannot_be_written_says_how_many_went_before():
    class Full(io.BytesIO):
        def write(self, b):
            if self.tell() > 4000:
                raise OSError(28, "No space left on device")
            return super().write(b)

    w = Writer(Full(), chunk_size=1024, compression=CompressionType.NONE)
    w.start(profile="", library="test")
    cid = w.register_channel("/c", "json", w.register_schema("s", "jsonschema", b"{}"))
    fm = FastMessages.attach(w)
    msgs = [(cid, 10**18 + i, b"x" * 100) for i in range(200)]
    try:
        fm.add_batch(msgs, 10**18)
    except OSError as exc:
        added = exc.added
    else:
        raise AssertionError("the full stream did not refuse a chunk")
    # the chunks written before held whole messages; the one that failed held `added + 1`
    assert 0 < added < 200
    assert added == w._Writer__statistics.message_count - 1
