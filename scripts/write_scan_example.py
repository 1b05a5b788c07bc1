"""Rewrite datasets/examples/lee_perry_smith.json: the built-in layout moved onto the scan.

Usage: python scripts/write_scan_example.py ../shared/realmeshes/lee_perry_smith_head.obj
The landmarks are the ones the example file records (picked on a front view of the scan);
the attachments go onto the level-set skull (datasets.skull.scan_skull) that load_face
builds under the scan. "skin" stays null: the scan is not shipped (load it with skin=...);
"unit" is "m".
"""

import dataclasses
import sys
from pathlib import Path

import wrinkle_vis as wv
from wrinkle_vis.datasets import BUILTIN_LAYOUT, read_surface, transfer_layout

example = Path(wv.datasets.__file__).with_name("examples") / "lee_perry_smith.json"
landmarks = wv.load_layout(example).landmarks
layout = transfer_layout(wv.load_layout(BUILTIN_LAYOUT), read_surface(sys.argv[1]), landmarks)
wv.save_layout(dataclasses.replace(layout, name="Lee Perry-Smith head scan (metres)",
                                   unit="m"), example)
print(f"wrote {example}")
