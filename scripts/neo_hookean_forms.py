#!/usr/bin/env python3
"""Uniaxial stress (lateral faces free) of the two compressible neo-Hookean energies the solver decks
carry, in closed form: ours and CalculiX's W = C10 (Ī₁ − 3) + (J − 1)²/D₁ (C10 = μ/2, D₁ = 2/K) and
FEBio's W = μ/2 (I₁ − 3) − μ ln J + λ/2 (ln J)² (FEBio user manual, "Neo-Hookean"), both from E and ν
with μ = E/(2(1+ν)), K = E/(3(1−2ν)), λ = K − 2μ/3. For each axial stretch λ₃ and ν it finds the lateral
stretch λ with ∂W/∂λ₁ = 0 by bisection and prints the nominal stress P₃₃ = ∂W/∂λ₃ over E, the lateral
stretch and how much larger |P₃₃| is in FEBio's form (negative: smaller). Usage: neo_hookean_forms.py [STRETCH ...] (default 0.95 0.9 0.85 0.8)."""
import math
import sys


def ours(l, nu):
    mu, k = 1 / (2 * (1 + nu)), 1 / (3 * (1 - 2 * nu))
    j = l[0] * l[1] * l[2]
    return mu / 2 * (j ** (-2 / 3) * sum(x * x for x in l) - 3) + k / 2 * (j - 1) ** 2


def febio(l, nu):
    mu, k = 1 / (2 * (1 + nu)), 1 / (3 * (1 - 2 * nu))
    lam, j = k - 2 * mu / 3, l[0] * l[1] * l[2]
    return mu / 2 * (sum(x * x for x in l) - 3) - mu * math.log(j) + lam / 2 * math.log(j) ** 2


def piola(w, l, i, nu, h=1e-6):
    up, down = list(l), list(l)
    up[i] += h
    down[i] -= h
    return (w(up, nu) - w(down, nu)) / (2 * h)


def uniaxial(w, l3, nu):
    """(P₃₃/E, lateral stretch) with the lateral faces free."""
    lo, hi = 0.5, 2.0
    for _ in range(100):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if piola(w, [mid, mid, l3], 0, nu) < 0 else (lo, mid)
    lat = (lo + hi) / 2
    return piola(w, [lat, lat, l3], 2, nu), lat


def main(stretches):
    # Check: both tend to the linear law (P₃₃ = E ε, lateral strain −ν ε) at small strain.
    for w in (ours, febio):
        p, lat = uniaxial(w, 1 - 1e-5, 0.3)
        assert abs(p / -1e-5 - 1) < 1e-4 and abs((lat - 1) / 1e-5 - 0.3) < 1e-3, w.__name__
    print("| compression | ν | P₃₃/E ours (CalculiX) | P₃₃/E FEBio | FEBio's \|P₃₃\| vs ours | lateral stretch ours | FEBio |")
    print("|---|---|---|---|---|---|---|")
    for l3 in stretches:
        for nu in (0.3, 0.45, 0.49):
            (p, a), (q, b) = uniaxial(ours, l3, nu), uniaxial(febio, l3, nu)
            print("| %g %% | %g | %.5f | %.5f | %+.2f %% | %.5f | %.5f |"
                  % (round((1 - l3) * 100, 6), nu, p, q, (abs(q) - abs(p)) / abs(p) * 100, a, b))


if __name__ == "__main__":
    main([float(s) for s in sys.argv[1:]] or [0.95, 0.9, 0.85, 0.8])
