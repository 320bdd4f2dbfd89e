"""Sensor-log files written byte by byte, without the writer's checks (what another tool, or
damage, might leave), for the tests of the readers."""
import io
import json
import zipfile

import numpy as np


def raw_npz_bytes(arrays: dict, meta) -> bytes:
    """An .npz holding `meta` (as JSON) and `arrays`, nothing checked."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        for name, arr in [("meta", np.array(json.dumps(meta)))] + list(arrays.items()):
            npy = io.BytesIO()
            np.lib.format.write_array(npy, np.asarray(arr), allow_pickle=False)
            zf.writestr(f"{name}.npy", npy.getvalue())
    return buf.getvalue()
