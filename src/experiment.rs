//! The paper's §4 experiments on generated data: Scheme 1, PSO, GA and the exact optimum.
