"""Reads E57 files with libE57Format (through pye57), the reference implementation, and checks
that every scan's records all read: prints per scan its name, record count, fields and pose.
Exits 1 when a file cannot be opened or a scan gives fewer values than its record count.
Usage (through scripts/check_e57.sh, which installs pye57): check_e57.py FILE.e57..."""
import sys

import pye57

bad = 0
for path in sys.argv[1:]:
    try:
        e = pye57.E57(path)
        print(f"{path}: {e.scan_count} scan(s)")
        for i in range(e.scan_count):
            h = e.get_header(i)
            # pye57's reader takes only the standard fields it knows (not returnIndex or an
            # extension's); the others are skipped, not a failure of the file.
            data = e.read_scan_raw(i, ignore_unsupported_fields=True)
            counts = {k: len(v) for k, v in data.items()}
            ok = all(c == h.point_count for c in counts.values())
            print(f"  scan {i}: {h.point_count} records, fields {sorted(data)}, "
                  f"rotation {[float(v) for v in h.rotation]}, "
                  f"translation {[float(v) for v in h.translation]}"
                  + ("" if ok else f"  FAILED: value counts {counts}"))
            bad += not ok
    except Exception as ex:  # any failure of the reference reader is a finding
        print(f"{path}: FAILED: {ex}")
        bad += 1
sys.exit(1 if bad else 0)
