"""`pushgrasp scene ...`: list, render and import scenes. Heavy modules are imported inside the handlers."""

from __future__ import annotations

import argparse
from pathlib import Path

from pg_sim.world.sim_mode import SIM_MODES


def add_parser(sub: argparse._SubParsersAction) -> None:
    scene = sub.add_parser("scene", help="list, render and import scenes")
    cmds = scene.add_subparsers(dest="scene_command", metavar="SUBCOMMAND", required=True)

    ls = cmds.add_parser("list", help="list the shipped scenes (name, objects, target)")
    ls.set_defaults(run=_list)

    render = cmds.add_parser("render", help="settle a scene and save camera image + heightmaps as one PNG")
    render.add_argument("scene", help="shipped scene name (see `scene list`), a scene YAML file, or random-N")
    render.add_argument("--out", required=True, type=Path, help="output PNG path")
    render.add_argument("--seed", type=int, default=0, help="seed for generated scenes (default 0)")
    render.set_defaults(run=_render)

    gallery = cmds.add_parser("gallery", help="render example scenes of generated families into one PNG each")
    gallery.add_argument("families", nargs="+", help="generated scenes, e.g. novel-10 novel-packed-8 mixed-15")
    gallery.add_argument("--out-dir", required=True, type=Path, help="folder for <family>.png")
    gallery.add_argument("--seeds", type=int, nargs="+", default=[1000000, 1000001, 1000002],
                         help="seeds, one scene per seed (default 1000000 1000001 1000002)")
    gallery.set_defaults(run=_gallery)

    objects = cmds.add_parser("objects", help="list the object catalogue: kinds, household categories, splits and "
                                              "id ranges")
    objects.set_defaults(run=_objects)

    household = cmds.add_parser("household-gallery", help="render training and held-out examples of each household "
                                                          "category at rest, one PNG per category")
    household.add_argument("--out-dir", required=True, type=Path, help="folder for <category>.png")
    household.add_argument("categories", nargs="*", help="categories to render (default: all)")
    household.set_defaults(run=_household_gallery)

    from pg_sim.scenes.vpg_import import add_arguments

    imp = cmds.add_parser("import-vpg", help="convert a VPG/Xu text test case to a scene YAML (rows parked outside "
                                             "the source workspace are left out and listed)")
    add_arguments(imp)
    imp.set_defaults(run=_import)

    bench = cmds.add_parser("bench", help="median wall time of one primitive and one observation in clutter")
    bench.add_argument("--objects", type=int, default=20, help="objects in the random scene (default 20)")
    bench.add_argument("--primitives", type=int, default=20, help="primitives to time (default 20)")
    bench.add_argument("--observations", type=int, default=20, help="observations to time (default 20)")
    bench.add_argument("--seed", type=int, default=0, help="scene and action seed (default 0)")
    bench.add_argument("--sim-mode", nargs="+", choices=list(SIM_MODES), default=list(SIM_MODES),
                       help="simulation modes to time, each from the same seed (default: all, with the ratio to the "
                            "first)")
    bench.set_defaults(run=_bench)

    from pg_sim.world.grasp_probe import add_arguments as probe_arguments

    probe = cmds.add_parser("grasp-probe", help="success of grasps at the cells a policy could pick on household "
                                                "objects (rims, walls, handles, blades), per grasp-height rule")
    probe_arguments(probe)
    probe.set_defaults(run=_grasp_probe)

    from pg_sim.world.throw_probe import add_arguments as throw_arguments

    throw = cmds.add_parser("throw-probe", help="how far grasps off a household object's centre move it when they "
                                                "miss (objects squeezed out between finger and table)")
    throw_arguments(throw)
    throw.set_defaults(run=_throw_probe)


def _list(args: argparse.Namespace) -> int:
    from pg_sim.scenes.scene import find_scene, list_scenes, load_scene

    for name in list_scenes():
        scene = load_scene(find_scene(name))
        print(f"{name:24s} {len(scene.objects):3d} objects  target {scene.target}")
    from pg_sim.world.scene_families import FAMILIES

    for family, fam in FAMILIES.items():
        what = "blocks" if fam.split is None else f"{fam.split} objects" + (" and blocks" if fam.block_share else "")
        print(f"{family + '-N':24s} N {what} dropped over +-{fam.half_extent} m from a seed (--seed)")
    return 0


def _gallery(args: argparse.Namespace) -> int:
    from pg_sim.world.render import render_gallery_png

    for family in args.families:
        out = render_gallery_png(family, args.seeds, args.out_dir / f"{family}.png")
        print(f"wrote {out}")
    return 0


def _objects(args: argparse.Namespace) -> int:
    from pg_sim.objects.catalog import KINDS, household_ids, object_ids
    from pg_sim.objects.household import CATEGORIES

    train, held = object_ids("train"), object_ids("heldout")
    print(f"{'kind':12s} {'train':>6s} {'held-out':>9s}  held-out ids")
    for kind in KINDS:
        ids = held[kind]
        span = ", ".join(i.split("/")[1] for i in ids) if kind == "named" else f"{ids[0]} .. {ids[-1]}"
        print(f"{kind:12s} {len(train[kind]):6d} {len(ids):9d}  {span}")
    train, held = household_ids("train"), household_ids("heldout")
    print(f"\n{'household':12s} {'train':>6s} {'held-out':>9s}  held-out ids: main dimension band; variants")
    for kind, cat in CATEGORIES.items():
        ids = held[kind]
        only = f" (held-out only: {', '.join(cat.held_variants)})" if cat.held_variants else ""
        print(f"{kind:12s} {len(train[kind]):6d} {len(ids):9d}  {ids[0]} .. {ids[-1]}: {cat.main} "
              f"{cat.held[0]:g}-{cat.held[1]:g} of {cat.span[0]:g}-{cat.span[1]:g}; {' '.join(cat.variants)}{only}")
    return 0


def _household_gallery(args: argparse.Namespace) -> int:
    from pg_sim.objects.catalog import HOUSEHOLD_KINDS
    from pg_sim.objects.household_gallery import render_category_png

    unknown = [c for c in args.categories if c not in HOUSEHOLD_KINDS]
    if unknown:
        raise ValueError(f"unknown household categories {unknown}; known: {', '.join(HOUSEHOLD_KINDS)}")
    for category in args.categories or HOUSEHOLD_KINDS:
        print(f"wrote {render_category_png(category, args.out_dir / f'{category}.png')}", flush=True)
    return 0


def _render(args: argparse.Namespace) -> int:
    from pg_sim.world.render import render_scene_png
    from pg_sim.world.scene_source import make_world_with_scene

    with make_world_with_scene(args.scene, args.seed) as world:
        render_scene_png(world, args.out)
    print(f"wrote {args.out}")
    return 0


def _bench(args: argparse.Namespace) -> int:
    from pg_sim.world.bench import run

    for name in ("objects", "primitives", "observations"):
        if getattr(args, name) < 1:
            raise ValueError(f"--{name} must be >= 1, got {getattr(args, name)}")
    results = []
    for mode in args.sim_mode:
        results.append(run(args.objects, args.primitives, args.observations, args.seed, mode))
        print(results[-1].report(), flush=True)
    first = results[0]
    for other in results[1:]:
        print(f"primitive median: {first.mode} {first.median_primitive_s:.3f} s, {other.mode} "
              f"{other.median_primitive_s:.3f} s ({other.mode} / {first.mode} = "
              f"{other.median_primitive_s / first.median_primitive_s:.2f})")
    return 0


def _grasp_probe(args: argparse.Namespace) -> int:
    from pg_sim.world.grasp_probe import execute

    return execute(args)


def _throw_probe(args: argparse.Namespace) -> int:
    from pg_sim.world.throw_probe import execute

    return execute(args)


def _import(args: argparse.Namespace) -> int:
    from pg_sim.scenes.vpg_import import run

    return run(args)
