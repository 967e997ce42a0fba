"""The pretrained human-pose model and the estimators built on it: the model itself
(`model`, the only importer of MediaPipe), the forearm's angle in the image (`planar`,
registry name ``pose``), the arm in 3-D (`spatial`: ``pose3d``, ``pose3d-depth``,
``pose-world``; the lifts are in `imimic_gym.spatial.lift`) and DON seeded by it
(`seeded_don`, ``pose-don``)."""
