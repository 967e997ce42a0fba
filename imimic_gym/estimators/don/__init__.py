"""DON, the paper's unsupervised vision-to-motion network (§3), layer by layer: frames to
moving pixels (`motion_mask`), moving regions as lines (`regions`), the pivot (`pivot`),
one link followed about it (`link_tracker`, `edge_memory`, `appearance`), the one-link
estimator (`one_link.DON`) and the tree of links (`linked.LinkedDON`, `chain_fit`), its
settings (`config`) and its compiled inner loops (`compiled`)."""
