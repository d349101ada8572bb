"""Learning pi_H: the policy-family protocol (``family``) and registry (``registry``), the
LEGATO and BC-RNN policies (``policies``), the Diffusion Policy baselines (``diffusion``),
encoders, normalisation, checkpoints and training.

Nothing here imports the robot side: a policy sees the gripper only (its images, its
pose-delta history and, in the privileged ``state`` mode, the recorder's state features).
"""
