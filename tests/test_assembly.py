"""The NLP's constant sparse matrices: scipy to CasADi (forte.planning.nlp.assembly.dm)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import sparse

from forte.planning.nlp.assembly import dm


def _cases() -> list[sparse.spmatrix]:
    rng = np.random.default_rng(7)
    cases = []
    for shape in [(3, 5), (5, 3), (4, 4), (1, 7), (7, 1), (0, 3), (3, 0), (40, 900), (900, 40)]:
        for density in (0.0, 0.1, 1.0):
            m = sparse.random(*shape, density=density, random_state=rng, format="coo")
            cases += [m, sparse.csr_matrix((np.ones(m.nnz), (m.row, m.col)), shape=shape)]  # values, ones
    cases.append(sparse.csr_matrix(([0.0, 1.0, 1.0], ([0, 1, 2], [2, 1, 0])), shape=(3, 5)))  # an explicit zero
    cases.append(sparse.csr_matrix(([1.0, 1.0, 1.0], ([0, 0, 2], [2, 2, 0])), shape=(3, 5)))  # a duplicate: 2
    return cases


@pytest.mark.parametrize("matrix", _cases(), ids=lambda m: f"{m.shape}-{m.nnz}")
def test_the_casadi_matrix_has_scipys_entries_and_stored_pattern(matrix):
    out = dm(matrix)
    csc = sparse.csc_matrix(matrix)
    csc.sort_indices()
    assert out.shape == matrix.shape
    np.testing.assert_array_equal(np.array(out.full()).reshape(matrix.shape), matrix.toarray())
    # the stored entries (explicit zeros too), column by column, in CasADi's order
    assert list(out.sparsity().colind()) == csc.indptr.tolist()
    assert list(out.sparsity().row()) == csc.indices.tolist()
    assert np.array(out.nonzeros()).tobytes() == np.asarray(csc.data, dtype=float).tobytes()
