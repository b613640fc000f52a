"""The reef paper's steps in Open3D, end to end as a user would run them on a file.

Run: ``python benchmarks/open3d_steps.py FIELD.xyz`` (Open3D from the ``bench`` extra; its
wheel needs Debian's ``libusb-1.0-0``). Open3D reads the ASCII file itself, then:
``remove_radius_outlier`` (r 0.5 m, noise if <= 3 neighbours), ``segment_plane`` (0.5 m, 3
points, 1000 iterations) and ``cluster_dbscan`` (eps 0.5 m, 10 points) on the points off the
plane. Prints the number of clusters: the peer that ``mbinspect reefs`` is timed beside
(``benchmarks/RESULTS.md``).
"""

from __future__ import annotations

import sys

import numpy as np


def main(path: str) -> None:
    import open3d as o3d

    pcd = o3d.io.read_point_cloud(path, format="xyz")
    pcd = pcd.translate(-pcd.get_center())  # a local frame, as ours works in
    pcd, _ = pcd.remove_radius_outlier(nb_points=4, radius=0.5)
    _, inliers = pcd.segment_plane(distance_threshold=0.5, ransac_n=3, num_iterations=1000)
    reef = pcd.select_by_index(inliers, invert=True)
    labels = np.asarray(reef.cluster_dbscan(eps=0.5, min_points=10))
    print(f"{len(pcd.points)} soundings kept, {int(labels.max() + 1) if len(labels) else 0} clusters")


if __name__ == "__main__":
    main(sys.argv[1])
