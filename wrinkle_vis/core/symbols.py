"""How the paper's symbols read: ``"k_0"`` as ``k₀``, ``"h^c"`` as ``hᶜ``, ``"Phi"`` as Φ.

Parameters (:class:`~wrinkle_vis.core.params.Parameter`) and fields
(:class:`~wrinkle_vis.core.fields.FieldSpec`) declare an ASCII label or key (their API names,
which messages, files and the command line use) and the paper's symbol; what people read in
the app and on scalar bars is made from these here, once.
"""

from __future__ import annotations

__all__ = ["ascii_spelling", "display_label", "pretty_symbol"]

#: Greek letters and their ASCII spellings in labels and keys.
GREEK = {"α": "alpha", "β": "beta", "γ": "gamma", "δ": "delta", "ε": "eps", "θ": "theta",
         "Θ": "Theta", "κ": "kappa", "λ": "lambda", "μ": "mu", "ρ": "rho", "σ": "sigma",
         "τ": "tau", "φ": "phi", "Φ": "Phi", "ω": "omega"}
#: The subscripts and superscripts Unicode has (others keep ``_x`` / ``^x``).
SUBSCRIPTS = dict(zip("0123456789aehijklmnoprstuvx", "₀₁₂₃₄₅₆₇₈₉ₐₑₕᵢⱼₖₗₘₙₒₚᵣₛₜᵤᵥₓ", strict=True))
SUPERSCRIPTS = dict(zip("0123456789abcdefhijklmnoprstuvwxyz",
                        "⁰¹²³⁴⁵⁶⁷⁸⁹ᵃᵇᶜᵈᵉᶠʰⁱʲᵏˡᵐⁿᵒᵖʳˢᵗᵘᵛʷˣʸᶻ", strict=True))


def pretty_symbol(symbol: str) -> str:
    """``symbol`` with ``_x`` as a subscript and ``^x`` as a superscript where Unicode has
    one for every character of ``x`` (``"k_0"`` -> ``k₀``, ``"h^c"`` -> ``hᶜ``,
    ``"R_s"`` -> ``Rₛ``); else as written (``"φ_c"``: there is no subscript c).
    """
    for mark, table in (("_", SUBSCRIPTS), ("^", SUPERSCRIPTS)):
        base, found, script = symbol.partition(mark)
        if found and script and all(c in table for c in script):
            return base + "".join(table[c] for c in script)
    return symbol


def ascii_spelling(symbol: str) -> str:
    """``symbol`` spelt in ASCII as labels spell it: ``"φ_c"`` -> ``phi_c``."""
    return "".join(GREEK.get(c, c) for c in symbol)


def _bare(text: str) -> str:
    return text.replace("_", "").replace("^", "")


def display_label(label: str, symbol: str) -> str:
    """What people read for the ASCII ``label`` of a value whose symbol is ``symbol``: the
    label's first word, when it spells the symbol, as the symbol
    (:func:`pretty_symbol`), and powers of units as superscripts: ``"Phi (deg)"`` -> ``Φ
    (deg)``, ``"k0"`` -> ``k₀``, ``"h_c"`` -> ``hᶜ``, ``"kappa (N/m^3)"`` -> ``κ (N/m³)``;
    a label in words (``"depth"``) as it is.
    """
    head, sep, rest = label.partition(" ")
    if symbol and _bare(head) == _bare(ascii_spelling(symbol)):
        head = pretty_symbol(symbol)
    for power in "23":
        rest = rest.replace(f"^{power}", SUPERSCRIPTS[power])
    return head + sep + rest
