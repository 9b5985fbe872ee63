#!/usr/bin/env python3
"""Issue 33 diagnostic, `python3 interop/rest_times.py BASETEMP` (a pytest --basetemp of
interop/test_rope_calibration.py). Per run dir: for each accepted move (status 0x190 answer 1), the time from its end
(accept + 8 s) to the last cycle with a non-zero trolley or winch set point (RPDO1
0x201/0x202 target velocity) before the next accept, and the largest |trolley set
point| from 1 s after the end, mm/s."""
import re, sys, glob
for f in sorted(glob.glob(sys.argv[1] + "/**/frames.log", recursive=True)):
    accepts, sp = [], []
    seen = set()
    for line in open(f):
        m = re.match(r'\((\S+)\) ecu (\S+)#([0-9A-F]*)', line)
        if not m: continue
        t, i, d = float(m[1]), m[2], bytes.fromhex(m[3])
        if i == '190' and d[1] == 1 and d[0] not in seen:
            seen.add(d[0]); accepts.append(t)
        if i in ('201', '202'):
            sp.append((t, i, int.from_bytes(d[2:6], 'little', signed=True)))
    out = []
    for k, a in enumerate(accepts):
        end = a + 8.0
        nxt = accepts[k + 1] if k + 1 < len(accepts) else float('inf')
        moving = [t for (t, i, v) in sp if end <= t < nxt and v != 0]
        last = max(moving) if moving else end
        late = [abs(v) / 1000 for (t, i, v) in sp if i == '201' and end + 1.0 <= t < nxt]
        out.append(f"{last - end:.2f}s/{max(late, default=0):.0f}")
    print(f.split('/')[-3], f.split('/')[-2], ' '.join(out))
