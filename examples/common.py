"""What the differentiable-simulation examples share: the iCub with a welded base, Adam, matplotlib, the default device.

Not an example: `trajectory_optimisation.py` and `system_identification.py` import it (examples/ is on
sys.path when one of them runs as a script).
"""

import numpy as np
import warp as wp

import warpdyn as wd


def fixed_base_icub(height: float = 1.0, **build) -> wd.model.Model:
    """iCubGazeboV2_5 with its root link welded to the world `height` metres above the ground (keyword
    arguments go to Model.build_from_model_description: dtype, device, time_step)."""
    try:
        import icub_models
    except ImportError:
        raise SystemExit("this example needs the iCub's URDF: pip install icub-models") from None
    W_H_B = np.eye(4)
    W_H_B[2, 3] = height
    path = icub_models.get_model_file("iCubGazeboV2_5")
    return wd.model.Model.build_from_model_description(path, fixed_base=True, base_pose=W_H_B, **build)


class Adam:
    """Adam (Kingma and Ba, 2015) on a NumPy array, with a learning rate given per step."""

    def __init__(self, shape, beta1=0.9, beta2=0.999, eps=1e-8):
        self.m, self.v, self.k = np.zeros(shape), np.zeros(shape), 0
        self.beta1, self.beta2, self.eps = beta1, beta2, eps

    def step(self, x: np.ndarray, g: np.ndarray, lr: float) -> np.ndarray:
        self.k += 1
        self.m = self.beta1 * self.m + (1.0 - self.beta1) * g
        self.v = self.beta2 * self.v + (1.0 - self.beta2) * g * g
        m_hat = self.m / (1.0 - self.beta1**self.k)
        v_hat = self.v / (1.0 - self.beta2**self.k)
        return x - lr * m_hat / (np.sqrt(v_hat) + self.eps)


def pyplot():
    """matplotlib.pyplot on its file backend (Agg); a SystemExit naming the extra when matplotlib is missing."""
    try:
        import matplotlib
    except ImportError:
        raise SystemExit("the plot needs matplotlib: pip install -e \".[examples]\" (or pass --plot '' for none)") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def default_device() -> str:
    return "cuda" if wp.get_cuda_device_count() > 0 else "cpu"
