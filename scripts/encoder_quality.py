"""Size and fidelity of the videos' x264 settings on ARCADE's frames, against mediapy's defaults (not timed).

Usage::

    python scripts/encoder_quality.py [--frames 40] [--json out/encoder_quality.json]
    MJFLEX_RECORD=1 python scripts/encoder_quality.py   # also docs/results/encoder_quality.json

Renders ``--frames`` states of the paper's run as scripts/demo.py's encoder measurement does (the
demo's fast look, labelled, at each of its sizes), encodes them with the demo's settings
(:data:`mjflex.app.render.ENCODER`) and with mediapy's defaults, decodes each video with the same
ffmpeg, and records per size and encoder: bytes per frame, and the PSNR of the decoded frames
against the rendered ones (8-bit RGB, from the mean squared error over every pixel of every frame;
x264 is deterministic, so a rerun gives the same bytes; a rerun on another GL may render slightly
different frames). The encoders' CPU time is scripts/demo.py's (timed) measurement.
"""

import argparse
import os
import tempfile

import imageio_ffmpeg
import numpy as np
from _bench import write_json
from demo import ENCODERS, SIZES, _states

from mjflex.app import render


def encode_and_compare(frames, settings, fps=30):
    """``(bytes per frame, PSNR [dB])`` of ``frames`` encoded with ``settings`` (None: mediapy's defaults)."""
    media = render._ffmpeg()
    kwargs = {} if settings is None else {"qp": settings["qp"], "ffmpeg_args": ["-preset", settings["preset"]]}
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "v.mp4")
        with media.VideoWriter(path, shape=frames[0].shape[:2], fps=fps, **kwargs) as writer:
            for image in frames:
                writer.add_image(image)
        size = os.path.getsize(path)
        reader = imageio_ffmpeg.read_frames(path)  # mediapy's reader passes -vsync, which ffmpeg 8 refuses
        width, height = next(reader)["size"]
        decoded = np.stack([np.frombuffer(b, np.uint8).reshape(height, width, 3) for b in reader])
    if decoded.shape != np.shape(frames):
        raise RuntimeError(f"decoded {decoded.shape}, encoded {np.shape(frames)}: the video lost frames")
    error = decoded.astype(np.float64) - np.asarray(frames, np.float64)
    mse = float(np.mean(error**2))
    return size / len(frames), 10.0 * np.log10(255.0**2 / mse)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=40, help="ARCADE states of the paper's run (default 40)")
    ap.add_argument("--json", default=os.path.join("out", "encoder_quality.json"))
    args = ap.parse_args()
    model, flex, run = _states(args.frames)
    rows = []
    for w, h in SIZES:
        with render.RunRenderer(model, flex, run, width=w, height=h, look=render.FAST) as renderer:
            frames = [renderer.frame(k) for k in range(len(run.time))]
            gl = render.gl_info()
        for name, settings in ENCODERS.items():
            size, psnr = encode_and_compare(frames, settings)
            rows.append({"width": w, "height": h, "encoder": name, "bytes_per_frame": size, "psnr_db": psnr})
            print(f"{w}x{h} {name:<32} {size / 1e3:5.1f} kB a frame, PSNR {psnr:.2f} dB", flush=True)
    write_json(args.json, {"frames": len(run.time), "look": render.FAST.name, "encoders": rows,
                           "gl": {"renderer": gl.renderer, "software": gl.software}})  # fmt: skip


if __name__ == "__main__":
    main()
