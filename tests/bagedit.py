"""Edit a ROS 2 bag message by message: restamp, repeat, drop, corrupt (the tests' way of making
a clean simulated bag look like what real robots record).

:func:`edit_bag` copies a bag, passing each edited topic's ``(bag_ns, message)`` list through a
function; the functions below make the artefacts real recordings have (arrival bursts, late
messages, duplicates, holes).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from rosbags.rosbag2 import Reader, Writer
from rosbags.typesys import Stores, get_typestore

TS = get_typestore(Stores.ROS2_HUMBLE)


def stamp_ns(msg) -> int:
    s = msg.header.stamp
    return int(s.sec) * 10**9 + int(s.nanosec)


def restamp(msg, ns: int):
    stamp = TS.types["builtin_interfaces/msg/Time"](sec=int(ns // 10**9), nanosec=int(ns % 10**9))
    return dataclasses.replace(msg, header=dataclasses.replace(msg.header, stamp=stamp))


def edit_bag(src, dst, **edits):
    """Copy the bag ``src`` to ``dst``; ``edits[key]`` (key: a topic without its slash) turns the
    list of that topic's ``(bag_ns, message)`` into the list to write (the other topics are
    copied as they are)."""
    with Reader(src) as r:
        topics = {c.topic: c for c in r.connections}
        streams: dict[str, list] = {t: [] for t in topics}
        for c, ns, raw in r.messages():
            edit = c.topic.strip("/") in edits
            streams[c.topic].append((ns, TS.deserialize_cdr(raw, c.msgtype) if edit else bytes(raw)))
    out = []
    for topic, msgs in streams.items():
        f = edits.get(topic.strip("/"))
        for ns, msg in f(msgs) if f else msgs:
            out.append((ns, topic, msg if f is None else TS.serialize_cdr(msg, topics[topic].msgtype)))
    out.sort(key=lambda m: m[0])
    with Writer(dst, version=9) as w:
        conns = {t: w.add_connection(t, c.msgtype, typestore=TS) for t, c in topics.items()}
        for ns, topic, raw in out:
            w.write(conns[topic], ns, raw)
    return dst


def chain(*edits):
    """The edits applied one after the other."""

    def f(msgs):
        for e in edits:
            msgs = e(msgs)
        return msgs

    return f


def arrival_bursts(n: int, spacing_ns: int = 20_000):
    """Messages stamped (and recorded) when they arrive, ``n`` at a time: each with the stamp of
    the last of its group, ``spacing_ns`` apart."""

    def f(msgs):
        out = []
        for i, (_, m) in enumerate(msgs):
            last = msgs[min(len(msgs) - 1, (i // n) * n + n - 1)][1]
            ns = stamp_ns(last) + (i % n) * spacing_ns
            out.append((ns, restamp(m, ns)))
        return out

    return f


def late_copies(every: int, after_s: float, spare_end_s: float = 2.0):
    """Every ``every``-th message sent again ``after_s`` later, stamped on arrival (content older
    than its stamp); none in the last ``spare_end_s`` (nothing would come after it)."""

    def f(msgs):
        end = stamp_ns(msgs[-1][1]) - int(spare_end_s * 1e9)
        out = list(msgs)
        for i in range(every, len(msgs), every):
            ns = stamp_ns(msgs[i][1]) + int(round(after_s * 1e9))
            if ns < end:
                out.append((ns, restamp(msgs[i][1], ns)))
        return sorted(out, key=lambda x: x[0])

    return f


def duplicated(share: float, seed: int = 0):
    """A share of the messages recorded twice (same stamp, same content)."""

    def f(msgs):
        rng = np.random.default_rng(seed)
        out = []
        for ns, m in msgs:
            out.append((ns, m))
            if rng.random() < share:
                out.append((ns + 1, m))
        return out

    return f


def dropped(share: float, seed: int = 1):
    """A share of the messages lost."""

    def f(msgs):
        rng = np.random.default_rng(seed)
        return [x for x in msgs if rng.random() >= share]

    return f


def hole(start_s: float, length_s: float):
    """No message from ``start_s`` (after the first stamp) for ``length_s``."""

    def f(msgs):
        t0 = stamp_ns(msgs[0][1])
        a, b = t0 + int(start_s * 1e9), t0 + int((start_s + length_s) * 1e9)
        return [(ns, m) for ns, m in msgs if not a <= stamp_ns(m) < b]

    return f


def wireless_odometry(rate_hz: float = 10.0, late_share: float = 0.01, seed: int = 3, bursts: bool = True):
    """An odometry sent over a wireless link: thinned to ``rate_hz``, arriving in bursts (mostly
    pairs, sometimes 3 to 7 messages, the last up to 5 ms after it was made; ``bursts`` False:
    each as made) and stamped on arrival; ``late_share`` of the messages followed by a copy of
    one made 0.2 to 1 s earlier."""

    def f(msgs):
        rng = np.random.default_rng(seed)
        step = int(round(1e9 / rate_hz))
        thin, nxt = [], stamp_ns(msgs[0][1])
        for _, m in msgs:
            if stamp_ns(m) >= nxt:
                thin.append(m)
                nxt += step
        out, k = [], 0
        while k < len(thin):
            size = (2 if rng.random() < 0.8 else int(rng.integers(3, 8))) if bursts else 1
            group = thin[k : k + size]
            arrival = stamp_ns(group[-1]) + (int(rng.uniform(0, 5e6)) if bursts else 0)
            for j, m in enumerate(group):
                ns = arrival + j * 200_000
                out.append((ns, restamp(m, ns)))
                back = int(rng.integers(2, 11))
                if rng.random() < late_share and k + j >= back:
                    out.append((ns + 100_000, restamp(thin[k + j - back], ns + 100_000)))
            k += len(group)
        return sorted(out, key=lambda x: x[0])

    return f
