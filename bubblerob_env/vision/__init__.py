"""What the forward camera sees: the simulator's ground truth and a recogniser to score against it.

- :mod:`~bubblerob_env.vision.geometry`: bearing and distance of scene objects from the camera's
  pose (no pixels involved).
- :mod:`~bubblerob_env.vision.ground_truth`: MuJoCo's segmentation rendering of a camera frame
  and, from it, one labelled box per visible obstacle and wall.
- :mod:`~bubblerob_env.vision.recognise`: a classical recogniser (colour segmentation, connected
  components, shading cues) that finds the obstacles in an RGB frame.
- :mod:`~bubblerob_env.vision.scoring`: matches detections to the ground truth and counts.

Obstacles are recognisable when the env paints them (``obstacle_colours=True``).
"""
