"""Learning pi_H: encoders, the LEGATO and BC-RNN policies, normalisation, training.

Nothing here imports the embodiment modules: a policy sees the gripper only (its images, its
pose-delta history and, in the privileged ``state`` mode, the recorder's state features).
"""
