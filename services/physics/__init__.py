"""PyBullet plays Gazebo's part: the converted build as a scene, Husky robots, a sim clock, attach and place.

Pure-ish core (:mod:`.simulation`, owning a DIRECT pybullet client; no bus) plus a thin Zenoh adapter
(:mod:`.app`) and the ``bimbot physics`` command (:mod:`.cli`).
"""
