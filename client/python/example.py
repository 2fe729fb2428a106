#!/usr/bin/env python3
"""Example: open a scene on a running pbgid, gather irradiance at a few
floor points, render one small tile, print what came back.

    example.py --server unix:./cache/pbgid.sock --proto-path build/python \
        scenes/cornell.usda
"""
import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pbgi_client import PbgiClient, PbgiError  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene")
    parser.add_argument("--server", default=os.environ.get("PBGI_SERVER", "unix:./cache/pbgid.sock"))
    parser.add_argument("--token", default=os.environ.get("PBGI_TOKEN"))
    parser.add_argument("--tls-ca", default=os.environ.get("PBGI_TLS_CA"))
    parser.add_argument("--proto-path", help="the build's python/ directory (pbgi_pb2)")
    parser.add_argument("--target-surfels", type=int, default=0)
    args = parser.parse_args()

    with PbgiClient(args.server, token=args.token, tls_ca=args.tls_ca,
                    proto_path=args.proto_path) as client:
        scene = os.path.abspath(args.scene) if os.path.isfile(args.scene) else args.scene
        build = {"target_surfels": args.target_surfels} if args.target_surfels else {}
        info = client.open_scene(
            scene, build=build, progress=lambda stage, f, eta: print(f"open: {stage} {100 * f:.0f}%",
                                                         file=sys.stderr))
        print(f"scene {info.scene_id}: {info.surfel_count} surfels, cameras {list(info.cameras)}")
        positions = [(-0.9, 0.001, 0.4), (0.9, 0.001, 0.4), (0.0, 0.001, 0.4)]
        normals = [(0, 1, 0)] * len(positions)
        out = client.gather(info.scene_id, positions, normals, light_samples=4)
        for p, e, ao in zip(positions, out["irradiance"], out["ao"]):
            print(f"irradiance at {p}: {e[0]:.4f} {e[1]:.4f} {e[2]:.4f}  ao {ao:.3f}")
        # The daemon may gather a subset and interpolate the rest
        # (interpolation=INTERPOLATION_OFF gathers every receiver).
        stats = out["stats"]
        print(f"gathered {stats.receivers} of {stats.requested_receivers} receivers")
        # A glossy receiver (roughness 0.1, white F0) on the floor in front
        # of the tall box, whose mirror direction points at the red left wall.
        mirror = (-0.958, 0.287, 0.0)  # unit, 17 degrees above the floor
        view = (-mirror[0], mirror[1], -mirror[2])  # reflected about the normal (0, 1, 0)
        glossy = client.gather(info.scene_id, [(-0.3, 0.001, 0.5)], [(0, 1, 0)],
                               view_directions=[view], roughness=[0.1],
                               specular_color=[(1, 1, 1)], light_samples=4)["glossy"][0]
        print(f"glossy towards {view}: {glossy[0]:.4f} {glossy[1]:.4f} {glossy[2]:.4f}")
        if info.cameras:
            tile = client.render_tile(info.scene_id, info.cameras[0], 64, 64, (24, 48, 40, 64),
                                      light_samples=4)
            mean = sum(sum(rgb) for rgb in tile["beauty"]) / (3 * len(tile["beauty"]))
            print(f"tile: {len(tile['beauty'])} pixels, mean beauty {mean:.4f}")
        try:
            client.gather(info.scene_id, [(float("nan"), 0, 0)], [(0, 1, 0)])
        except PbgiError as e:
            print(f"refused as expected: {e.code.name}")
        status = client.status()
        print(f"status: {len(status.scenes)} scenes, cache {status.cache.misses} misses")
    return 0


if __name__ == "__main__":
    sys.exit(main())
