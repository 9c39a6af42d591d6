#!/usr/bin/env python3
"""How far a phone model's learned pose corrections brought its frames back to the truth.

    python3 tools/frame_pose_error.py ROOM PHONE_ROOM MODEL [CAPTURE]

ROOM is the room as rendered (true poses), PHONE_ROOM its `neuroom degrade --phone` copy (tracked
poses), MODEL a model folder trained on the copy (its config.json holds the corrections of the
training frames: every frame but each 10th, the held-out ones). CAPTURE defaults to `background`,
whose rays live in the room's frame. For each training frame it reports the rotation error, the
camera centre's error, and the error of the point it sees: the frame's pivot (the centroid of what
its depth shows) carried through the true camera and back out through the tracked or corrected
pose. The last lines repeat the seen-point error after the best rigid alignment of all frames to the
truth (Horn's method), since the model's frame may sit a little off the room's. Standard library only.
"""
import json
import math
import sys

HOLDOUT = 10


def mat(m):
    return [row[:3] for row in m[:3]], [m[i][3] for i in range(3)]


def mm(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def mv(a, v):
    return [sum(a[i][k] * v[k] for k in range(3)) for i in range(3)]


def tr(a):
    return [[a[j][i] for j in range(3)] for i in range(3)]


def sub(a, b):
    return [x - y for x, y in zip(a, b)]


def add(a, b):
    return [x + y for x, y in zip(a, b)]


def norm(a):
    return math.sqrt(sum(x * x for x in a))


def rodrigues(w):
    th = norm(w)
    if th < 1e-12:
        return [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    k = [x / th for x in w]
    c, s = math.cos(th), math.sin(th)
    kx = [[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]]
    kk = mm(kx, kx)
    return [[(i == j) + s * kx[i][j] + (1 - c) * kk[i][j] for j in range(3)] for i in range(3)]


def angle_deg(a, b):
    r = mm(tr(a), b)
    return math.degrees(math.acos(max(-1.0, min(1.0, (r[0][0] + r[1][1] + r[2][2] - 1) / 2))))


def horn(p, q):
    """The rotation and translation that best carry points p onto q (least squares)."""
    n = len(p)
    cp = [sum(x[i] for x in p) / n for i in range(3)]
    cq = [sum(x[i] for x in q) / n for i in range(3)]
    s = [[sum((p[k][i] - cp[i]) * (q[k][j] - cq[j]) for k in range(n)) for j in range(3)] for i in range(3)]
    (sxx, sxy, sxz), (syx, syy, syz), (szx, szy, szz) = s
    big = [
        [sxx + syy + szz, syz - szy, szx - sxz, sxy - syx],
        [syz - szy, sxx - syy - szz, sxy + syx, szx + sxz],
        [szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy],
        [sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz],
    ]
    shift = sum(abs(x) for row in big for x in row) + 1.0
    v = [1.0, 0.0, 0.0, 0.0]
    for _ in range(2000):  # power iteration: the largest eigenvector is the rotation's quaternion
        w = [sum((big[i][j] + (shift if i == j else 0.0)) * v[j] for j in range(4)) for i in range(4)]
        v = [x / norm(w) for x in w]
    a, b, c, d = v
    r = [
        [a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c)],
        [2 * (b * c + a * d), a * a - b * b + c * c - d * d, 2 * (c * d - a * b)],
        [2 * (b * d - a * c), 2 * (c * d + a * b), a * a - b * b - c * c + d * d],
    ]
    return r, sub(cq, mv(r, cp))


def main():
    if len(sys.argv) not in (4, 5):
        sys.exit(__doc__)
    room, phone, model = sys.argv[1:4]
    capture = sys.argv[4] if len(sys.argv) == 5 else "background"
    truth = json.load(open(f"{room}/captures/{capture}/transforms.json"))["frames"]
    tracked = json.load(open(f"{phone}/captures/{capture}/transforms.json"))["frames"]
    frames = json.load(open(f"{model}/config.json"))["trainer"].get("frames")
    if not frames:
        sys.exit(f"{model}/config.json: no frame corrections (trained without them)")
    params, pivots = frames["params"], frames["pivots"]
    train = [i for i in range(len(truth)) if i % HOLDOUT != 0]
    if len(train) * 9 != len(params):
        sys.exit(f"{model}: {len(params) // 9} corrected frames, the capture has {len(train)} training frames")
    poses = {"tracked": [], "corrected": []}
    seen = {"tracked": [], "corrected": []}
    errors = {"rotation (deg)": {}, "centre (cm)": {}, "seen point (cm)": {}}
    for name in poses:
        for key in errors:
            errors[key][name] = []
    for f, i in enumerate(train):
        r_true, o_true = mat(truth[i]["transform_matrix"])
        r_tracked, o_tracked = mat(tracked[i]["transform_matrix"])
        w, tau, p = params[9 * f:9 * f + 3], params[9 * f + 3:9 * f + 6], pivots[f]
        turn = rodrigues(w)
        candidates = {
            "tracked": (r_tracked, o_tracked),
            "corrected": (mm(turn, r_tracked), add(add(p, mv(turn, sub(o_tracked, p))), tau)),
        }
        local = mv(tr(r_true), sub(p, o_true))  # the pivot as the true camera sees it
        for name, (r, o) in candidates.items():
            placed = add(mv(r, local), o)
            seen[name].append((placed, p))
            errors["rotation (deg)"][name].append(angle_deg(r_true, r))
            errors["centre (cm)"][name].append(100 * norm(sub(o_true, o)))
            errors["seen point (cm)"][name].append(100 * norm(sub(placed, p)))
    for key, by in errors.items():
        cells = [f"{name} mean {sum(v) / len(v):.2f} max {max(v):.2f}" for name, v in by.items()]
        print(f"{key}: " + "; ".join(cells))
    for name, pairs in seen.items():
        r, t = horn([a for a, _ in pairs], [b for _, b in pairs])
        aligned = [100 * norm(sub(add(mv(r, a), t), b)) for a, b in pairs]
        turn = angle_deg([[1, 0, 0], [0, 1, 0], [0, 0, 1]], r)
        print(
            f"{name}, aligned ({turn:.2f} deg, {100 * norm(t):.2f} cm): seen point mean "
            f"{sum(aligned) / len(aligned):.2f} max {max(aligned):.2f} cm"
        )


if __name__ == "__main__":
    main()
