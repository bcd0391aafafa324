#!/usr/bin/python3
"""Worked example: two sessions on chromod, their maps in numpy, plotted and compared.

    python3 examples/maps_example.py [TARGET] [--token T] --out DIR

1. runs the standard session twice (progress printed by a callback);
2. loads each session's maps at full resolution as numpy arrays (Client.maps);
3. plots Cm and Ch with colour bars and the histogram of Cm and Ch in a
   region (the centre of the lit skin) → DIR/maps.png;
4. relights the first session's maps under CIE A on the daemon and shows the
   relit picture → DIR/relight_a.png (when the daemon's folder is on this
   machine);
5. compares the two sessions in the region (median Cm, Ch; difference map)
   → DIR/compare.png;
6. reads the first session again from its folder with no daemon
   (open_session, through maps.ome.tiff) and checks it equals the API's maps.

Needs the chromosphere package (pip install ./clients/python) and matplotlib.
"""
import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # headless: files only
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import chromosphere  # noqa: E402


def region(maps: chromosphere.Maps, size: int = 64):
    """A square at the centre of the explained pixels (the lit skin)."""
    ys, xs = np.nonzero(maps.explained())
    if len(ys) == 0:
        raise SystemExit("no explained pixels in the maps")
    cy, cx = int(np.median(ys)), int(np.median(xs))
    half = min(size, maps.width, maps.height) // 2
    return slice(max(0, cy - half), cy + half), slice(max(0, cx - half), cx + half)


def region_values(maps: chromosphere.Maps, name: str, box) -> np.ndarray:
    values = maps[name][box]
    return values[maps.explained()[box] & np.isfinite(values)]


def plot_maps(maps: chromosphere.Maps, box, path: Path) -> None:
    fig, axes = plt.subplots(2, 2, figsize=(10, 8))
    for ax, name, cmap in ((axes[0, 0], "Cm", "copper_r"), (axes[0, 1], "Ch", "Reds")):
        shown = np.where(maps.explained(), maps[name], np.nan)
        image = ax.imshow(shown, cmap=cmap)
        ax.add_patch(plt.Rectangle((box[1].start, box[0].start), box[1].stop - box[1].start,
                                   box[0].stop - box[0].start, fill=False, edgecolor="cyan"))
        ax.set_title(f"{name} ({maps.channel(name).meaning})", fontsize=8)
        fig.colorbar(image, ax=ax, label=maps.unit(name))
    for ax, name in ((axes[1, 0], "Cm"), (axes[1, 1], "Ch")):
        values = region_values(maps, name, box)
        ax.hist(values, bins=40, color="grey")
        ax.set_xlabel(f"{name} ({maps.unit(name)})")
        ax.set_ylabel("pixels")
        ax.set_title(f"{name} in the region: median {np.median(values):.4f}, {len(values)} pixels", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("target", nargs="?", default=None, help="unix:/path/chromod.sock or host:port")
    parser.add_argument("--token", default=None, help="bearer token (TCP)")
    parser.add_argument("--out", type=Path, required=True, help="folder for the figures")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)

    def show(p: chromosphere.Progress) -> None:
        print(f"  {p.state:<10} {p.progress * 100:5.1f}% stored {p.frames_stored}/{p.frames_expected}  {p.message}")

    with chromosphere.Client(args.target, token=args.token) as client:
        runs, all_maps = [], []
        for subject in ("forearm, first", "forearm, second"):
            run = client.run_session(subject, on_progress=show)
            print(f"session {run.id}: {run.state}, {run.frames_stored} frames")
            if not run.succeeded:
                print(f"session failed: {run.message}", file=sys.stderr)
                return 1
            maps = client.maps(run.id)
            print(f"maps: {maps.width}x{maps.height}, channels {', '.join(maps.names)}; "
                  f"Cm in {maps.unit('Cm')}, flags {', '.join(maps.flag_names)}")
            runs.append(run)
            all_maps.append(maps)

        first, second = all_maps
        box = region(first)
        plot_maps(first, box, args.out / "maps.png")
        print(f"region rows {box[0].start}-{box[0].stop}, columns {box[1].start}-{box[1].stop}")

        relit = client.relight(runs[0].id, "A", label="example")
        print(f"relit under {relit.illuminant}: {relit.relit_pixels} pixels → {relit.out_dir}")
        folder = Path(client.results(runs[0].id).folder)
        pictures = [folder / f for f in relit.files if f.endswith(".png")]
        if pictures and pictures[0].is_file():
            fig, ax = plt.subplots(figsize=(6, 5))
            ax.imshow(plt.imread(pictures[0]))
            ax.set_title(f"session {runs[0].id} relit under CIE A", fontsize=8)
            ax.axis("off")
            fig.savefig(args.out / "relight_a.png", dpi=80)
            plt.close(fig)

        fig, axes = plt.subplots(1, 3, figsize=(13, 4))
        for ax, name in zip(axes[:2], ("Cm", "Ch")):
            a, b = region_values(first, name, box), region_values(second, name, box)
            ax.hist([a, b], bins=40, label=["first", "second"])
            ax.set_xlabel(f"{name} ({first.unit(name)})")
            ax.legend()
            print(f"{name} median in the region: first {np.median(a):.4f}, second {np.median(b):.4f}, "
                  f"difference {np.median(b) - np.median(a):+.4f}")
        both = first.explained() & second.explained()
        difference = np.where(both, second["Cm"] - first["Cm"], np.nan)
        limit = float(np.nanpercentile(np.abs(difference), 99)) or 1e-3  # the noise, not the rare outlier
        image = axes[2].imshow(difference, cmap="coolwarm", vmin=-limit, vmax=limit)
        fig.colorbar(image, ax=axes[2], label="ΔCm (second − first)")
        axes[2].set_title("Cm: second − first", fontsize=8)
        fig.tight_layout()
        fig.savefig(args.out / "compare.png", dpi=80)
        plt.close(fig)

        if (folder / "session.json").is_file():
            stored = chromosphere.open_session(folder)
            from_disk = stored.maps()
            same = all(np.array_equal(from_disk[n], first[n], equal_nan=True) for n in first.names)
            print(f"stored session {stored.id}: {len(stored.frames)} frames, maps from maps.ome.tiff "
                  f"{'equal' if same else 'DIFFERENT'} to the API's")
            if not same:
                return 1
    print(f"figures in {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
