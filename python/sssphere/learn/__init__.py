"""Learning the canonical sphere problem: the three CVAEs of the paper (LengthGen, PathGen,
EventGen), their training data, training, export to the model file format
(docs/model-format.md) and a NumPy reference decoder.

Only the NumPy parts are imported here; ``models``, ``train`` and ``export`` need the ``learn``
extra (PyTorch, onnxscript, onnx, onnxruntime) and are imported on demand::

    from sssphere.learn import numpy_decoder            # NumPy only
    from sssphere.learn.train import train               # needs torch

See docs/learning.md.
"""

from sssphere.learn.data import DataError, TrainingData, load_training_data
from sssphere.learn.numpy_decoder import ModelFileError, NumpyDecoder, SphereSampler, load_decoder

__all__ = [
    "DataError",
    "ModelFileError",
    "NumpyDecoder",
    "SphereSampler",
    "TrainingData",
    "load_decoder",
    "load_training_data",
]
