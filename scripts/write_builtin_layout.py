"""Rewrite datasets/builtin_layout.json from the code (run after changing the layout)."""

from wrinkle_vis.core import save_layout
from wrinkle_vis.datasets.face import BUILTIN_LAYOUT, builtin_layout

save_layout(builtin_layout(), BUILTIN_LAYOUT)
print(f"wrote {BUILTIN_LAYOUT}")
