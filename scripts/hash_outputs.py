#!/usr/bin/env python3
"""Hash every dataset of every HDF5 file under one or more output folders, or compare two.

    hash_outputs.py DIR                 print `file/dataset sha256` lines for DIR
    hash_outputs.py --compare A B       exit 1 unless A and B hold the same files with
                                        bitwise-identical datasets (attributes are ignored:
                                        they hold the code version and wall-clock data)

Used to check that a refactor keeps scene outputs bitwise identical (needs h5py)."""
import hashlib
import os
import sys

import h5py


def manifest(root):
    out = {}
    for dirpath, _, files in sorted(os.walk(root)):
        for name in sorted(files):
            if not name.endswith(".h5"):
                continue
            path = os.path.join(dirpath, name)
            rel = os.path.relpath(path, root)
            with h5py.File(path, "r") as f:
                def visit(key, obj):
                    if isinstance(obj, h5py.Dataset):
                        data = obj[()]
                        h = hashlib.sha256()
                        h.update(str(data.dtype).encode())
                        h.update(str(data.shape).encode())
                        h.update(data.tobytes())
                        out[f"{rel}/{key}"] = h.hexdigest()
                f.visititems(visit)
    return out


def main(argv):
    if len(argv) == 2:
        for k, v in sorted(manifest(argv[1]).items()):
            print(k, v)
        return 0
    if len(argv) == 4 and argv[1] == "--compare":
        a, b = manifest(argv[2]), manifest(argv[3])
        bad = 0
        for k in sorted(set(a) | set(b)):
            if a.get(k) != b.get(k):
                bad += 1
                if bad <= 20:
                    print("DIFFERS:", k, a.get(k, "missing")[:12], b.get(k, "missing")[:12])
        print(f"{len(set(a) | set(b))} datasets compared, {bad} differ")
        return 1 if bad or not a else 0
    print(__doc__)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv))
