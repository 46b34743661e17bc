"""The compact L-BFGS direction is torch's two-loop direction, found by a few products."""

import pytest
import torch

from sklearn_pycc.backends.neural.lbfgs import CompactLBFGS, _Memory


def two_loop(pairs, g):
    """The textbook two-loop recursion: ``H g`` for pairs ``(s, y)``, oldest first."""
    q, alphas = g.clone(), []
    for s, y in reversed(pairs):
        alpha = s.dot(q) / y.dot(s)
        alphas.append(alpha)
        q -= alpha * y
    s, y = pairs[-1]
    r = q * (s.dot(y) / y.dot(y))
    for (s, y), alpha in zip(pairs, reversed(alphas)):
        r += s * (alpha - y.dot(r) / y.dot(s))
    return r


@pytest.mark.parametrize("stored", [1, 4, 5, 13])
def test_the_direction_is_the_two_loop_one_also_after_the_ring_wraps(stored):
    generator = torch.Generator().manual_seed(stored)
    n = 40
    A = torch.randn(n, n, generator=generator, dtype=torch.float64)
    A = A @ A.T + n * torch.eye(n, dtype=torch.float64)
    memory = _Memory(5, torch.zeros(n, dtype=torch.float64))
    pairs = []
    for _ in range(stored):
        s = torch.randn(n, generator=generator, dtype=torch.float64)
        y = A @ s
        memory.add(s, y, y.dot(s))
        pairs.append((s, y))
    g = torch.randn(n, generator=generator, dtype=torch.float64)
    expected = -two_loop(pairs[-5:], g)
    torch.testing.assert_close(memory.direction(g), expected, rtol=1e-10, atol=1e-12)


def rosenbrock_run(optimizer_class, steps=5):
    x = torch.tensor([-1.2, 1.0], dtype=torch.float64, requires_grad=True)
    optimizer = optimizer_class([x], max_iter=20, history_size=10,
                                line_search_fn="strong_wolfe")
    evaluations = 0

    def closure():
        nonlocal evaluations
        evaluations += 1
        optimizer.zero_grad()
        loss = (100 * (x[1:] - x[:-1] ** 2) ** 2 + (1 - x[:-1]) ** 2).sum()
        loss.backward()
        return loss

    for _ in range(steps):  # the state carries over from one call to the next
        optimizer.step(closure)
    return x.detach(), evaluations


def test_it_minimises_as_torch_lbfgs_does():
    ours, ours_evaluations = rosenbrock_run(CompactLBFGS)
    theirs, theirs_evaluations = rosenbrock_run(torch.optim.LBFGS)
    torch.testing.assert_close(ours, torch.ones(2, dtype=torch.float64), atol=1e-5, rtol=0)
    torch.testing.assert_close(ours, theirs, atol=1e-6, rtol=0)
    assert abs(ours_evaluations - theirs_evaluations) <= 5


def test_only_the_strong_wolfe_search_is_offered():
    with pytest.raises(ValueError, match="strong Wolfe"):
        CompactLBFGS([torch.zeros(2, requires_grad=True)], line_search_fn=None)
