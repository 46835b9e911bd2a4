"""The SLAM side of nFEX: dataset loaders, the visual odometry with a per-frame choice of extractor, trajectories
and ATE — and a replay client (``nfex_slam.replay``) that runs the VO over a sequence asking a running service
per frame.

``nfex_slam.datasets``, ``trajectory``, ``vo``, ``features``, ``motion`` and ``pairs`` need NumPy and OpenCV
only; the server (``nfex``) runs the same code in ``nfex evaluate`` and the sweeps. ``replay`` also needs
the HTTP client (``nfex-client``), so it is imported only where it is used.
"""
