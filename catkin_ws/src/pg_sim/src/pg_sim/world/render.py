"""Render what the robot sees: camera image, colour heightmap and height heightmap side by side, target outlined."""

from __future__ import annotations

from pathlib import Path

from pg_sim.world.world import World


def render_scene_png(world: World, out: Path, title: str | None = None) -> Path:
    """Capture the world and write a 3-panel PNG; returns the path. Target outline from ground truth (red)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    obs = world.observe()
    labels = world.label_heightmap(obs.frame)
    target = world.target_id
    g = world.geometry
    b = g.workspace.bounds
    extent = (b[0, 0], b[0, 1], b[1, 0], b[1, 1])  # col -> x, row -> y: origin lower so +y is up

    fig, axes = plt.subplots(1, 3, figsize=(15, 5), dpi=100)
    axes[0].imshow(obs.frame.color)
    axes[0].set_title("camera colour (640x480)")
    axes[1].imshow(obs.heightmap.color, origin="lower", extent=extent)
    axes[1].set_title("colour heightmap (x right, y up)")
    im = axes[2].imshow(obs.heightmap.height, origin="lower", extent=extent, cmap="viridis", vmin=0.0)
    axes[2].set_title("height heightmap (m)")
    fig.colorbar(im, ax=axes[2], fraction=0.046)
    if target is not None:
        axes[0].contour(obs.frame.segmentation == target, levels=[0.5], colors="red", linewidths=1.5)
        for ax in axes[1:]:
            ax.contour((labels == target).astype(float), levels=[0.5], colors="red", linewidths=1.5,
                       extent=extent, origin="lower")
    for ax in axes[1:]:
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
    name = world.scene.name if world.scene else "scene"
    visible = int((labels == target).sum()) if target is not None else 0
    fig.suptitle(title or f"{name}: {len(world.objects)} objects, target visible in {visible} heightmap cells")
    return _save(fig, out)


def render_gallery_png(family: str, seeds: list[int], out: Path) -> Path:
    """One row per seed of generated scene ``family``: camera image and colour heightmap with the target outlined
    (red) and its kind in the title. Raises ValueError for a name that is not a generated family."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pg_sim.world.scene_families import check_generated, generate_scene, target_kind

    check_generated(family)
    fig, axes = plt.subplots(len(seeds), 2, figsize=(9, 4.2 * len(seeds)), dpi=90, squeeze=False)
    for row, seed in zip(axes, seeds, strict=True):
        with World() as world:
            scene = generate_scene(world, family, seed)
            obs = world.observe()
            labels = world.label_heightmap(obs.frame)
            b = world.geometry.workspace.bounds
            extent = (b[0, 0], b[0, 1], b[1, 0], b[1, 1])
            tid = world.target_id
            kind = target_kind(scene.target_object.name)
            row[0].imshow(obs.frame.color)
            row[0].contour(obs.frame.segmentation == tid, levels=[0.5], colors="red", linewidths=1.2)
            row[0].set_title(f"{family} seed {seed}: camera")
            row[1].imshow(obs.heightmap.color, origin="lower", extent=extent)
            row[1].contour((labels == tid).astype(float), levels=[0.5], colors="red", linewidths=1.2, extent=extent,
                           origin="lower")
            row[1].set_title(f"colour heightmap; target: {kind} ({int((labels == tid).sum())} cells)")
            for ax in row:
                ax.set_xticks([])
                ax.set_yticks([])
    return _save(fig, out)


def _save(fig: object, out: Path) -> Path:
    """Lay out, write (folders made) and close a matplotlib figure; returns the path."""
    import matplotlib.pyplot as plt

    fig.tight_layout()  # type: ignore[attr-defined]
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out)  # type: ignore[attr-defined]
    plt.close(fig)  # type: ignore[arg-type]
    return out
