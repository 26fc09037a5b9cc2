"""What the benchmarks read of a process in Linux's /proc: its resident memory, its
CPU time, and the tree of processes a run started (its session's group and every
descendant). One home for these, so that every benchmark measures them alike.
"""

from __future__ import annotations

import os

PAGE = os.sysconf("SC_PAGE_SIZE")
TICK = os.sysconf("SC_CLK_TCK")


class Stat(tuple):
    """(parent pid, process group, CPU ticks (user + system), start time in ticks)."""

    __slots__ = ()

    @property
    def ppid(self) -> int:
        return self[0]

    @property
    def pgid(self) -> int:
        return self[1]

    @property
    def ticks(self) -> int:
        return self[2]

    @property
    def start(self) -> int:
        return self[3]


def stat(pid: int | str) -> Stat | None:
    """/proc/<pid>/stat of a live process (None when gone or a zombie)."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            text = f.read()
    except OSError:
        return None
    fields = text[text.rfind(b")") + 2:].split()  # the name may hold spaces and ')'
    if not fields or fields[0] in (b"Z", b"X"):
        return None
    return Stat((int(fields[1]), int(fields[2]), int(fields[11]) + int(fields[12]), int(fields[19])))


def cpu_seconds(pid: int | None) -> float | None:
    """User + system CPU seconds of a live process, or None."""
    st = stat(pid) if pid is not None else None
    return None if st is None else st.ticks / TICK


def rss(pid: int) -> int:
    """Resident bytes of a process now (0 when gone)."""
    try:
        with open(f"/proc/{pid}/statm", "rb") as f:
            return int(f.read().split()[1]) * PAGE
    except (OSError, IndexError, ValueError):
        return 0


def status(pid: int) -> dict[str, int]:
    """VmRSS and its high-water mark VmHWM, in bytes ({} when gone)."""
    out: dict[str, int] = {}
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                k, _, v = line.partition(":")
                if k in ("VmRSS", "VmHWM"):
                    out[k] = int(v.split()[0]) * 1024
    except OSError:
        pass
    return out


def tree(leader: int) -> dict[int, Stat]:
    """The run's live processes with their stat: its session's group (the leader's pid,
    as the run was started in a new session) and every descendant of the leader,
    wherever it went."""
    info: dict[int, Stat] = {}
    for name in os.listdir("/proc"):
        if name.isdigit():
            st = stat(name)
            if st is not None:
                info[int(name)] = st
    out: dict[int, Stat] = {}
    for pid, st in info.items():
        member = st.pgid == leader
        p, hops = pid, 0
        while not member and p > 1 and hops < 64:
            if p == leader:
                member = True
                break
            p, hops = (info[p].ppid if p in info else 0), hops + 1
        if member:
            out[pid] = st
    return out
