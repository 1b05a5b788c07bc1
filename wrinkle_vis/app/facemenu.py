"""Which face the window shows, for its title and the Face menu (no Qt widgets built here).

A session shows a built-in face (:data:`wrinkle_vis.datasets.FACES`) when its layout names
no skin mesh: :attr:`Layout.face` says which (None: the procedural face). A layout that
names its skin is a face from a scan, whose landmarks can be picked again.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["FACE_LABELS", "builtin_face", "can_pick_again", "face_title", "mark_face"]

#: The Face menu's entries for the built-in faces (``&``: the menu's mnemonic).
FACE_LABELS = {"procedural": "&Procedural", "lee_perry_smith": "&Lee Perry-Smith"}


def face_label(name: str) -> str:
    """The built-in face ``name`` as the menu and the title name it (no mnemonic)."""
    return FACE_LABELS.get(name, name.replace("_", " ").title()).replace("&", "")


def builtin_face(session) -> str | None:
    """The name of the built-in face ``session`` shows (a key of :data:`FACE_LABELS`), or
    None for a face from a scan.
    """
    from wrinkle_vis.datasets import FACES

    layout = session.base_layout  # where the skin comes from (not the edits: cheap)
    if layout.skin is not None:
        return None
    name = layout.face or "procedural"
    return name if name in FACES else None


def can_pick_again(session) -> bool:
    """Whether the landmarks of the face ``session`` shows can be picked again: a face from
    a scan, whose layout names its mesh, with landmarks, and a folder the mesh path starts
    from. Built-in faces have no scan landmarks to pick.
    """
    return (session.base_layout.skin is not None and bool(session.face.landmarks)
            and session.folder is not None)


def face_title(session) -> str:
    """The window title: the layout file's name, else which face is shown; ``*`` marks
    unsaved changes.
    """
    if session.layout_path is not None:
        what = session.layout_path.name
    elif (name := builtin_face(session)) is not None:
        what = f"built-in face {face_label(name)}"
    else:
        what = f"new face from {Path(session.base_layout.skin).name}"
    return f"wrinkle-vis - {what}{' *' if session.dirty else ''}"


def mark_face(actions: dict, session) -> None:
    """Check the Face menu's action (in ``actions``, by face name) of the built-in face
    ``session`` shows, and uncheck the others (none checked on a face from a scan).
    """
    shown = builtin_face(session)
    for name, action in actions.items():
        if action.isChecked() != (name == shown):
            action.setChecked(name == shown)
