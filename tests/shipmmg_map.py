"""usvid's MMG parameters as shipmmg's (Yasukawa & Yoshimura 2015 in shipmmg's names), for the
cross-checks in the tests and the peer in ``benchmarks/bench_mmg.py``: one mapping."""

from __future__ import annotations

from typing import Any


def shipmmg_params(sm: Any, p: Any) -> tuple[Any, Any]:
    """(basic, manoeuvring) parameter sets of module ``sm`` (``shipmmg.mmg_3dof``) for the
    usvid :class:`MMGParameters` ``p``: masses from the non-dimensional added masses times
    ``q_mass`` (0.5 rho L^2 d), lengths from fractions of L to metres."""
    q = p.q_mass
    basic = sm.Mmg3DofBasicParams(
        L_pp=p.L, B=p.B, d=p.d, x_G=p.x_G, D_p=p.D_p, m=p.m, I_zG=p.I_zG, A_R=p.A_R, η=p.eta,
        m_x=p.m_x * q, m_y=p.m_y * q, J_z=p.J_z * q * p.L ** 2, f_α=p.f_alpha, ϵ=p.epsilon,
        t_R=p.t_R, x_R=p.x_R * p.L, a_H=p.a_H, x_H=p.x_H * p.L, γ_R_minus=p.gamma_R_minus,
        γ_R_plus=p.gamma_R_plus, l_R=p.l_R, κ=p.kappa, t_P=p.t_P, w_P0=p.w_P0, x_P=p.x_P)
    man = sm.Mmg3DofManeuveringParams(
        k_0=p.k_0, k_1=p.k_1, k_2=p.k_2, R_0_dash=p.R_0, X_vv_dash=p.X_vv, X_vr_dash=p.X_vr,
        X_rr_dash=p.X_rr, X_vvvv_dash=p.X_vvvv, Y_v_dash=p.Y_v, Y_r_dash=p.Y_r,
        Y_vvv_dash=p.Y_vvv, Y_vvr_dash=p.Y_vvr, Y_vrr_dash=p.Y_vrr, Y_rrr_dash=p.Y_rrr,
        N_v_dash=p.N_v, N_r_dash=p.N_r, N_vvv_dash=p.N_vvv, N_vvr_dash=p.N_vvr,
        N_vrr_dash=p.N_vrr, N_rrr_dash=p.N_rrr)
    return basic, man
