"""Pictures of the scripted baseline for the README, drawn by the CPU renderer.

    python examples/render_scripted.py --out docs/scripted.png   # a strip of stills
    python examples/render_scripted.py --out docs/scripted.gif   # an animation (render extra)

One seeded episode of ``panda_rapier.ScriptedPolicy``; the same seed gives the same bytes.
A GIF is encoded by the ffmpeg that imageio-ffmpeg bundles (with a palette made for it); the
PNG needs nothing beyond numpy.
"""

from __future__ import annotations

import argparse
import struct
import zlib
from pathlib import Path

import gymnasium as gym
import numpy as np

import panda_rapier


def write_png(path: Path, rgb: np.ndarray) -> None:
    """An 8-bit RGB PNG (the format is simple enough not to need an imaging library)."""
    height, width, _ = rgb.shape
    raw = b"".join(b"\x00" + rgb[y].tobytes() for y in range(height))

    def chunk(tag: bytes, data: bytes) -> bytes:
        crc = zlib.crc32(tag + data) & 0xFFFFFFFF
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", crc)

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    path.write_bytes(
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", header)
        + chunk(b"IDAT", zlib.compress(raw, 9))
        + chunk(b"IEND", b"")
    )


def write_gif(path: Path, frames: list[np.ndarray], fps: float) -> None:
    import imageio_ffmpeg

    height, width, _ = frames[0].shape
    writer = imageio_ffmpeg.write_frames(
        str(path),
        (width, height),
        fps=fps,
        codec="gif",
        pix_fmt_out="pal8",
        macro_block_size=1,
        ffmpeg_log_level="error",
        output_params=["-vf", "split[a][b];[a]palettegen=max_colors=128[p];[b][p]paletteuse"],
    )
    writer.send(None)
    for frame in frames:
        writer.send(np.ascontiguousarray(frame))
    writer.close()


def episode_frames(seed: int, width: int, height: int) -> list[np.ndarray]:
    env = gym.make(
        "panda_rapier/PickAndPlace-v0", render_mode="rgb_array", width=width, height=height
    )
    policy = panda_rapier.ScriptedPolicy(env)
    obs, _ = env.reset(seed=seed)
    frames = [env.render()]
    for _ in range(70):
        action, _ = policy.predict(obs, deterministic=True)
        obs, _, terminated, truncated, _ = env.step(action)
        frames.append(env.render())
        if terminated or truncated:
            break
    env.close()
    return frames


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help=".png (stills) or .gif")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--width", type=int, default=360)
    parser.add_argument("--height", type=int, default=240)
    parser.add_argument(
        "--stills", type=int, nargs="+", default=[0, 18, 30, 50], help="steps shown in the PNG"
    )
    args = parser.parse_args()
    frames = episode_frames(args.seed, args.width, args.height)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    if args.out.suffix == ".gif":
        # Every second frame at half the control rate: real time, half the file.
        write_gif(args.out, frames[::2], fps=12.5)
    else:
        write_png(args.out, np.concatenate([frames[k] for k in args.stills], axis=1))
    print(f"{len(frames)} frames rendered; wrote {args.out}")


if __name__ == "__main__":
    main()
