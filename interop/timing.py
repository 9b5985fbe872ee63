"""The bus's timing in an ECU frame log (`frames.log`, candump `-l` layout, the ECU's wall
clock): who was late when the controller dropped a drive for fault 10 (EMCY 0x8250, "drive
TPDOs stopped for 50 ms").

    python interop/timing.py target/interop/pytest/<test>/run0/frames.log

prints the SYNCs' spacing (a gap over 15 ms: the ECU's tick thread was late; SYNCs under
2 ms apart: ticks run back to back), each drive's TPDO1 after its SYNC (its latency, and
the most SYNCs that went out between two of its TPDOs: the controller's fault 10 needs
six), the controller's EMCYs, and for every fault 10 the SYNCs and TPDOs of the 150 ms
before it. The ECU stalled shows as a SYNC gap (then, before the schedule slipped, a
burst); the drives stalled as SYNCs on time that no TPDO answers.
"""

import argparse
import bisect

SYNC, EMCY_CONTROLLER = 0x080, 0x090
TPDO1 = 0x180
TPDO_TIMEOUT = bytes([0x50, 0x82])  # EMCY 0x8250, little-endian


def frames(path):
    """(time, sender, id, data) of every line."""
    out = []
    with open(path) as f:
        for line in f:
            stamp, sender, frame = line.split()
            can_id, data = frame.split("#")
            out.append((float(stamp.strip("()")), sender, int(can_id, 16), bytes.fromhex(data)))
    return out


def report(path, nodes):
    log = frames(path)
    syncs = [t for (t, s, i, _) in log if i == SYNC and s == "ecu"]
    gaps = [b - a for a, b in zip(syncs, syncs[1:])]
    lines = [
        f"{len(syncs)} SYNCs: largest gap {max(gaps, default=0) * 1e3:.1f} ms, "
        f"{sum(g > 0.015 for g in gaps)} gaps over 15 ms, {sum(g < 0.002 for g in gaps)} under 2 ms"
    ]
    emcys = [(t, d) for (t, s, i, d) in log if i == EMCY_CONTROLLER and s == "ecu"]
    lines.append("controller EMCYs: " + (", ".join(f"{t:.3f} s {d.hex()}" for t, d in emcys) or "none"))
    for node in nodes:
        tpdos = [t for (t, s, i, _) in log if i == TPDO1 + node and s != "ecu"]
        after = sorted(t - syncs[k - 1] for t in tpdos if (k := bisect.bisect_left(syncs, t)) > 0)
        if not after:
            continue
        between = [bisect.bisect_left(syncs, b) - bisect.bisect_left(syncs, a) for a, b in zip(tpdos, tpdos[1:])]
        lines.append(
            f"node {node}: {len(tpdos)} TPDO1s, after their SYNC median {after[len(after) // 2] * 1e3:.2f} ms, "
            f"max {after[-1] * 1e3:.1f} ms; at most {max(between, default=0)} SYNCs between two"
        )
    cobs = {SYNC, EMCY_CONTROLLER} | {TPDO1 + n for n in nodes}
    for t_fault, data in emcys:
        if data[:2] != TPDO_TIMEOUT:
            continue
        lines.append(f"fault 10 (EMCY {data.hex()}, node {data[4]}) at {t_fault:.6f} s; the 150 ms before:")
        lines += [
            f"  {t:.6f} {s:5} {i:03X} {d.hex()}" for (t, s, i, d) in log if i in cobs and t_fault - 0.15 <= t <= t_fault
        ]
    return lines


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("log", help="the ECU's frames.log")
    p.add_argument("--nodes", default="1,2,4", help="the drives' node ids (1,2,4: the planar and 3D cranes')")
    args = p.parse_args()
    print("\n".join(report(args.log, [int(n) for n in args.nodes.split(",")])))


if __name__ == "__main__":
    main()
