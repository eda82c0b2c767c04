import numpy as np
import torch

from acder_lite.algo.normalizer import Normalizer


def test_matches_numpy_mean_std():
    rng = np.random.default_rng(0)
    x = rng.normal(3.0, 2.0, size=(1000, 4))
    n = Normalizer(4, eps=0.01, clip=5.0)
    for chunk in np.array_split(x, 7):
        n.update(chunk)
    np.testing.assert_allclose(n.mean, x.mean(0), rtol=1e-10)
    np.testing.assert_allclose(n.std, x.std(0), rtol=1e-8)
    v = rng.normal(size=(5, 4))
    np.testing.assert_allclose(
        n.normalize(v), np.clip((v - x.mean(0)) / x.std(0), -5, 5), rtol=1e-8
    )
    t = n.normalize(torch.tensor(v, dtype=torch.float32))
    np.testing.assert_allclose(t.numpy(), n.normalize(v), rtol=1e-5, atol=1e-6)


def test_eps_floor_and_clip():
    n = Normalizer(2, eps=0.01, clip=5.0)
    n.update(np.ones((10, 2)))  # zero variance: std is the floor eps
    np.testing.assert_allclose(n.std, [0.01, 0.01])
    assert np.all(n.normalize(np.array([[2.0, 0.0]])) == [[5.0, -5.0]])


def test_state_dict_round_trip():
    n = Normalizer(3)
    n.update(np.arange(12.0).reshape(4, 3))
    m = Normalizer(3)
    m.load_state_dict(n.state_dict())
    np.testing.assert_array_equal(m.mean, n.mean)
    np.testing.assert_array_equal(m.std, n.std)
