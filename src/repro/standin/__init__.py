"""Stand-in data (layer 3): the body and pose solver (``pose``), concept motions
(``primitives``, ``locomotion``), the concept catalogue (``concepts``), captions, clips
(``generator``), datasets on disk (``dataset``), concept oracles, the caption vocabulary
(``text``) and notebook 00's figures. Imports the layers below.

Layers: docs/DESIGN.md."""
