"""PFM images for the bench scripts: linear float32 RGB, row 0 at the top."""
import numpy as np


def read_pfm(path):
    with open(path, "rb") as f:
        kind = f.readline().strip()
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4")
    ch = 3 if kind == b"PF" else 1
    img = data.reshape(h, w, ch)[::-1].astype(np.float64)
    return np.repeat(img, 3, axis=2) if ch == 1 else img
