"""Local porosity theory: local porosity and S_V distributions μ(φ, L), local percolation λ_α(φ, L), p_α(L)."""

__all__: list[str] = []
