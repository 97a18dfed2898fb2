"""C for 3 × 3 rotations, shared by the navigation generators (:mod:`nlobs.export.gnss_ins`, :mod:`nlobs.export.nav_ekf`).

The products ``A B``, ``A Bᵀ``, ``Aᵀ B`` of row-major 3 × 3 matrices with the sums of
:mod:`nlobs.navigation.split_kernel` (term for term, in the same order), and Rodrigues' formula
``exp(S(φ))`` in the fused form of :func:`nlobs.navigation.split_kernel.exp_so3_scalar`, so that the C
reproduces the Python single-flight kernels to rounding.
"""

from __future__ import annotations

from typing import Any

__all__ = ["expso3_c", "mat3_c"]


def mat3_c(P: str, which: tuple[str, ...] = ("mm", "mmT", "mTm")) -> str:
    """``static void P_mm``, ``P_mmT``, ``P_mTm``: ``o = A B``, ``A Bᵀ``, ``Aᵀ B`` (the split kernel's sums).

    Parameters
    ----------
    P : str
        The module's C prefix.
    which : tuple of str
        The functions to write (a static function the module does not call fails a strict build).

    Returns
    -------
    str
        The three static C functions.
    """
    def body(ix: Any) -> str:
        rows = []
        for i in range(3):
            for j in range(3):
                terms = " + ".join(f"A[{ix(i, k, j)[0]}] * B[{ix(i, k, j)[1]}]" for k in range(3))
                rows.append(f"    o[{3 * i + j}] = {terms};")
        return "\n".join(rows)

    index = {"mm": lambda i, k, j: (3 * i + k, 3 * k + j), "mmT": lambda i, k, j: (3 * i + k, 3 * j + k),
             "mTm": lambda i, k, j: (3 * k + i, 3 * k + j)}
    funcs = [f"static void {P}_{name}(const double *A, const double *B, double *o)\n{{\n{body(index[name])}\n}}\n"
             for name in which]
    return "/* o = A B, o = A B^T, o = A^T B (row-major 3x3; o distinct from A and B) */\n" + "\n".join(funcs)


def expso3_c(P: str) -> str:
    """``static void P_expso3(p0, p1, p2, E)``: Rodrigues' ``exp(S(φ))`` as ``exp_so3_scalar`` computes it.

    Parameters
    ----------
    P : str
        The module's C prefix.

    Returns
    -------
    str
        The static C function (after a blank line).
    """
    return f"""
/* Rodrigues: exp(S(phi)), the fused form of nlobs.navigation.split_kernel.exp_so3_scalar */
static void {P}_expso3(double p0, double p1, double p2, double *E)
{{
    const double th = sqrt(p0 * p0 + p1 * p1 + p2 * p2) + 1e-300;
    const double A = sin(th) / th;
    const double sh = sin(0.5 * th);
    const double r = sh / th;
    const double B = 2.0 * (r * r);
    const double c = 1.0 - 2.0 * sh * sh;
    const double Ap0 = A * p0, Ap1 = A * p1, Ap2 = A * p2;
    const double Bp0 = B * p0, Bp1 = B * p1, Bp2 = B * p2;
    E[0] = c + Bp0 * p0;
    E[1] = Bp0 * p1 - Ap2;
    E[2] = Bp0 * p2 + Ap1;
    E[3] = Bp1 * p0 + Ap2;
    E[4] = c + Bp1 * p1;
    E[5] = Bp1 * p2 - Ap0;
    E[6] = Bp2 * p0 - Ap1;
    E[7] = Bp2 * p1 + Ap0;
    E[8] = c + Bp2 * p2;
}}
"""
