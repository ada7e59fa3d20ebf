"""How frames become bytes.

Message templates -> ``struct`` items (``encode``), record headers and the index of packed frames
(``framing``), the one packer with ``pack_one``/``pack_many`` (``packer``), a distro's frames
(``serializer``) and the batch of gathered frames (``batch``). Imports ``messages`` only.
"""
