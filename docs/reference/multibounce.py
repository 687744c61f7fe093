#!/usr/bin/env python3
# Source: reference data handed to this project with the paper and the scenes, copied
# unchanged below this note (it produced multibounce.md).
"""
Exact multi-bounce (radiosity) reference values for closed configurations.
Radiosity equation (diffuse, per colour channel):  B_i = E_i + rho_i * sum_j F_ij B_j.
Prints the tables that are copied into multibounce.md.  Needs numpy; imports the closed-form
view factors from viewfactors.py (Howell C-11 / C-14).
"""
import math
import numpy as np
from viewfactors import parallel_rect, perp_rect_common_edge

RHOS = [0.5, 0.8, 0.9, 0.99, 0.999]


def bounces_needed(rho, tol):
    # truncated Neumann series after k bounces: B_k = E (1 - rho^(k+1)) / (1 - rho)
    # relative error rho^(k+1) <= tol  ->  k >= ln(tol)/ln(rho) - 1
    return max(0, math.ceil(math.log(tol) / math.log(rho) - 1 - 1e-12))


def box_F(dx, dy, dz):
    """6x6 face-to-face view factors of a closed dx*dy*dz box, faces ordered
    [x0, x1, y0, y1, z0, z1] (x0 = plane x=0, etc.). One patch per face."""
    dims = {"x": (dy, dz, dx), "y": (dx, dz, dy), "z": (dx, dy, dz)}
    axes = ["x", "y", "z"]
    F = np.zeros((6, 6))
    area = np.zeros(6)
    for ia, a in enumerate(axes):
        for s in range(2):
            i = 2 * ia + s
            # the face normal to axis a has extents along the other two axes
            others = [b for b in axes if b != a]
            ext = {"x": dx, "y": dy, "z": dz}
            area[i] = ext[others[0]] * ext[others[1]]
            for jb, b in enumerate(axes):
                for t in range(2):
                    j = 2 * jb + t
                    if i == j:
                        continue
                    if a == b:  # opposite face
                        F[i, j] = parallel_rect(ext[others[0]], ext[others[1]], ext[a])
                    else:  # adjacent face: common edge along the third axis c
                        c = [x for x in axes if x not in (a, b)][0]
                        # from face (c x b-extent) to face (c x a-extent), common edge = ext[c]
                        F[i, j] = perp_rect_common_edge(ext[b], ext[a], ext[c])
    return F, area


def solve(F, rho, E):
    n = len(E)
    R = np.diag(rho)
    return np.linalg.solve(np.eye(n) - R @ F, E)


def main():
    print("## white furnace B = E/(1-rho), E = 1")
    for r in RHOS:
        print("rho=%-6g B=%.10g  bounces for rel.err 1e-3: %d, 1e-6: %d" % (
            r, 1 / (1 - r), bounces_needed(r, 1e-3), bounces_needed(r, 1e-6)))

    print("\n## infinite parallel plates, E1=1, E2=0, rho1=rho2=rho")
    for r in RHOS:
        d = 1 - r * r
        print("rho=%-6g B1=%.10g B2=%.10g" % (r, 1 / d, r / d))
    print("\n## infinite parallel plates, RGB: plate1 rho=(0.725,0.71,0.68) E1=(1,1,1); plate2 rho=(0.63,0.065,0.05) E2=0")
    r1 = np.array([0.725, 0.71, 0.68])
    r2 = np.array([0.63, 0.065, 0.05])
    d = 1 - r1 * r2
    print("B1 =", ["%.10g" % x for x in 1 / d], " B2 =", ["%.10g" % x for x in r2 / d])

    print("\n## concentric spheres r1/r2 = 0.5 (F11=0,F12=1,F21=0.25,F22=0.75); inner emits E1=1, E2=0, rho1=rho2=rho")
    a = 0.25
    for r in RHOS:
        B2 = r * a / (1 - r * (1 - a) - r * r * a)
        B1 = 1 + r * B2
        # check with linear solve
        F = np.array([[0, 1], [a, 1 - a]])
        Bs = solve(F, np.array([r, r]), np.array([1.0, 0.0]))
        assert abs(Bs[0] - B1) < 1e-9 * B1 and abs(Bs[1] - B2) < 1e-9 * max(B2, 1)
        # identity: sum A B = sum A E / (1 - rho), A1=0.25, A2=1 (relative)
        lhs = 0.25 * B1 + 1.0 * B2
        rhs = 0.25 * 1 / (1 - r)
        print("rho=%-6g B_inner=%.10g B_outer=%.10g  (sum A_i B_i = %.10g, sum A_i E_i/(1-rho) = %.10g)" % (r, B1, B2, lhs, rhs))

    for name, dims in [("unit cube", (1.0, 1.0, 1.0)), ("closed box 556 x 548.8 x 559.2 (x,y,z; Cornell-box extents, y up)", (556.0, 548.8, 559.2))]:
        F, A = box_F(*dims)
        print("\n## %s, one patch per face, faces [x0,x1,y0,y1,z0,z1]" % name)
        print("areas:", ["%.6g" % x for x in A])
        print("F matrix (rows sum to 1 within %.1e; reciprocity max err %.1e):" % (
            np.max(np.abs(F.sum(1) - 1)), np.max(np.abs(A[:, None] * F - (A[:, None] * F).T))))
        for row in F:
            print("  " + " ".join("%.10f" % x for x in row))
        E = np.zeros(6)
        E[2] = 1.0  # y0 (floor, if y is up) emits
        for r in RHOS:
            B = solve(F, np.full(6, r), E)
            lhs = A @ B
            rhs = A @ E / (1 - r)
            print("rho=%-6g floor(y0) emits E=1: B = [%s]  sumAB/(sumAE/(1-rho)) - 1 = %.1e" % (
                r, ", ".join("%.10g" % x for x in B), lhs / rhs - 1))
        # white furnace on the box
        for r in (0.99, 0.999):
            B = solve(F, np.full(6, r), np.ones(6))
            print("furnace rho=%g E=1 all faces: B = [%s] (expect %.10g)" % (r, ", ".join("%.10g" % x for x in B), 1 / (1 - r)))
        # RGB, non-uniform: McGuire CornellBox-Original Kd values on the closed box
        # x0 = red (0.63,0.065,0.05), x1 = green (0.14,0.45,0.091), others white (0.725,0.71,0.68),
        # ceiling y1 emits E=(1,1,1)
        white = np.array([0.725, 0.71, 0.68])
        red = np.array([0.63, 0.065, 0.05])
        green = np.array([0.14, 0.45, 0.091])
        rho_rgb = [red, green, white, white, white, white]
        E = np.zeros(6)
        E[3] = 1.0
        print("RGB closed box: x0 red Kd(0.63,0.065,0.05), x1 green Kd(0.14,0.45,0.091), y0,y1,z0,z1 white Kd(0.725,0.71,0.68); ceiling y1 emits E=1 in each channel:")
        for ch, cname in enumerate("RGB"):
            B = solve(F, np.array([p[ch] for p in rho_rgb]), E)
            print("  %s: B = [%s]" % (cname, ", ".join("%.10g" % x for x in B)))


if __name__ == "__main__":
    main()
