#!/usr/bin/env python3
"""Random worlds in the shared scenario format, to run the pipeline's defaults on layouts nobody tuned them on.

Per seed one 2-D and one 3-D world (r2d_SEED.yaml, r3d_SEED.yaml):

  2-D  bounds 40x40 to 150x100 m, robot radius 0.2-0.8 m, one of four vehicles (1.5-6 m/s); rotated boxes, circles
       and ellipses scattered at one of three densities, none within a few robot radii of the start or the goal.
  3-D  three sizes up to 120x100x40 m; 3-8 hills, then floating spheres, 3-axis ellipsoids and yawed towers.

The same seed gives the same file. A world may happen to have no way through: check it on the ground truth first
(`ddsnav plan --scenario FILE --planner gart-lazy --kinodynamic`); `ddsnav bench-mission` does, and says so.

    python3 configs/scenarios/make_random_scenarios.py --seeds 1-10 --out /tmp/random
    ddsnav bench-mission --scenario /tmp/random/r2d_1.yaml --out /tmp/mb --speed 4
"""
import argparse
import math
import os
import random


def world_2d(seed):
    rng = random.Random(seed)
    width, height = rng.choice([(60, 40), (100, 80), (150, 100), (40, 40)])
    radius = rng.choice([0.2, 0.35, 0.5, 0.8])
    v_max, omega_max = rng.choice([(2.0, 0.8), (4.0, 0.6), (6.0, 0.5), (1.5, 1.2)])
    start, goal = (0.06 * width, 0.1 * height), (0.94 * width, 0.9 * height)
    area_per_obstacle = rng.choice([150, 250, 400])  # m^2: dense, medium, sparse
    obstacles = []
    for _ in range(int(width * height / area_per_obstacle)):
        x, y = rng.uniform(0, width), rng.uniform(0, height)
        kind, size = rng.random(), rng.uniform(1, 0.08 * min(width, height))
        keep_clear = size + 4 * radius + 3  # m from the start and the goal: both stay free
        if math.dist((x, y), start) <= keep_clear or math.dist((x, y), goal) <= keep_clear:
            continue
        if kind < 0.35:
            obstacles.append(f"{{type: sphere, center: [{x:.2f}, {y:.2f}], radius: {size / 2:.2f}}}")
        elif kind < 0.65:
            obstacles.append(f"{{type: box, center: [{x:.2f}, {y:.2f}], size: [{size:.2f}, {rng.uniform(0.5, 2.5):.2f}], "
                             f"yaw: {rng.uniform(-3, 3):.2f}}}")
        else:
            obstacles.append(f"{{type: ellipsoid, center: [{x:.2f}, {y:.2f}], semi_axes: [{size / 2:.2f}, "
                             f"{rng.uniform(0.4, 2):.2f}], yaw: {rng.uniform(-3, 3):.2f}}}")
    heading = rng.uniform(-3, 3)
    return scenario_text(f"r2d_{seed}", seed, (width, height), radius, (*start, heading), goal, max(1.0, 3 * radius),
                         f"v_max: {v_max:.1f}, omega_max: {omega_max:.2f}", obstacles)


def world_3d(seed):
    rng = random.Random(seed)
    width, depth, height = rng.choice([(80, 80, 30), (120, 100, 40), (60, 60, 25)])
    radius = rng.choice([0.3, 0.5, 0.7])
    start = (0.08 * width, 0.1 * depth, rng.uniform(4, 10))
    goal = (0.92 * width, 0.9 * depth, rng.uniform(6, 14))
    obstacles = []
    hills = []
    for _ in range(rng.randint(3, 8)):
        x, y = rng.uniform(0.2 * width, 0.8 * width), rng.uniform(0.2 * depth, 0.8 * depth)
        hill = (round(x, 1), round(y, 1), round(rng.uniform(5, 0.7 * height), 1), round(rng.uniform(4, 12), 1))
        hills.append(hill)
        obstacles.append(f"{{type: hill, center: [{hill[0]:.1f}, {hill[1]:.1f}], height: {hill[2]:.1f}, sigma: {hill[3]:.1f}}}")
    # A start or goal drawn inside a hill (seed 116: the start 0.5 m into one) is lifted out of it, a metre clear;
    # one that is free keeps its height (the same file as before for every seed that was valid).
    start = (*start[:2], clear_of_hills(start, radius, hills, height))
    goal = (*goal[:2], clear_of_hills(goal, radius, hills, height))
    for _ in range(rng.randint(2, 8)):
        x, y, z = rng.uniform(0, width), rng.uniform(0, depth), rng.uniform(3, 0.6 * height)
        if math.dist((x, y, z), start) < 10 or math.dist((x, y, z), goal) < 10:
            continue
        kind = rng.random()
        if kind < 0.4:
            obstacles.append(f"{{type: sphere, center: [{x:.1f}, {y:.1f}, {z:.1f}], radius: {rng.uniform(1.5, 5):.1f}}}")
        elif kind < 0.7:  # a tower standing on the ground
            obstacles.append(f"{{type: box, center: [{x:.1f}, {y:.1f}, {z / 2 + 1:.1f}], size: [{rng.uniform(2, 8):.1f}, "
                             f"{rng.uniform(2, 8):.1f}, {z + 2:.1f}], yaw: {rng.uniform(-3, 3):.2f}}}")
        else:
            obstacles.append(f"{{type: ellipsoid, center: [{x:.1f}, {y:.1f}, {z:.1f}], semi_axes: [{rng.uniform(2, 8):.1f}, "
                             f"{rng.uniform(1, 3):.1f}, {rng.uniform(1, 4):.1f}], yaw: {rng.uniform(-3, 3):.2f}}}")
    v_max, omega_max, vz_max = rng.choice([3, 5]), rng.choice([0.4, 0.7]), rng.choice([1, 2])
    return scenario_text(f"r3d_{seed}", seed, (width, depth, height), radius, start, goal, 2,
                         f"v_max: {v_max:.1f}, omega_max: {omega_max:.2f}, vz_max: {vz_max:.1f}", obstacles)


def terrain_height(x, y, hills):
    return max([h * math.exp(-((x - cx) ** 2 + (y - cy) ** 2) / (2 * sigma * sigma)) for cx, cy, h, sigma in hills] + [0.0])


def clear_of_hills(point, radius, hills, height):
    """The z of `point` if the robot's ball there is clear of every hill (checked on a grid over the ball), else the
    highest terrain under the ball plus the radius and a metre, below the ceiling."""
    x, y, z = point
    steps = [radius * k / 4 for k in range(-4, 5)]
    under = [(x + dx, y + dy, math.sqrt(max(0.0, radius * radius - dx * dx - dy * dy))) for dx in steps for dy in steps
             if dx * dx + dy * dy <= radius * radius]
    if all(z - half_chord > terrain_height(px, py, hills) for px, py, half_chord in under):
        return z
    highest = max(terrain_height(px, py, hills) for px, py, _ in under)
    return min(highest + radius + 1.0, height - radius - 0.5)


def scenario_text(name, seed, bounds_max, radius, start, goal, goal_radius, vehicle_limits, obstacles):
    """The file: the bounds start at the origin; `start` may carry a 2-D heading after its position."""
    def numbers(values):
        return ", ".join(f"{v:.2f}" for v in values)
    lines = [f"# make_random_scenarios.py, seed {seed}", f"name: {name}", f"dimensions: {len(bounds_max)}",
             f"bounds: {{min: [{', '.join('0' for _ in bounds_max)}], max: [{', '.join(str(v) for v in bounds_max)}]}}",
             f"robot_radius: {radius:.2f}", f"start: [{numbers(start)}]", f"goal: [{numbers(goal)}]",
             f"goal_radius: {goal_radius:.1f}", f"vehicle: {{model: unicycle, {vehicle_limits}, dt: 1.0}}", "obstacles:"]
    return "\n".join(lines + ["  - " + o for o in obstacles]) + "\n"


def seed_range(text):
    first, _, last = text.partition("-")
    first, last = int(first), int(last or first)
    if last < first or last - first >= 10000:
        raise argparse.ArgumentTypeError(f"--seeds: expected A-B with A <= B and at most 10000 seeds, got {text!r}")
    return range(first, last + 1)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=seed_range, default=seed_range("1-5"), help="A-B or one seed (default 1-5)")
    parser.add_argument("--out", required=True, help="directory for the files (created)")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    for seed in args.seeds:
        for name, text in ((f"r2d_{seed}.yaml", world_2d(seed)), (f"r3d_{seed}.yaml", world_3d(seed))):
            with open(os.path.join(args.out, name), "w") as f:
                f.write(text)
    print(f"{2 * len(args.seeds)} scenarios in {args.out}")


if __name__ == "__main__":
    main()
