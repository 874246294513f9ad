"""Sensors on the robot: the sonar facade (pings, scans, OFDM frames), the camera, the LiDAR and
depth-camera baselines, and robot trajectories with odometry."""
