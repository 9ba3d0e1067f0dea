//! The paper's method as pure geometry: line fits, line propagation, the constrained
//! multi-line objective, and the searchers for its corner (PSO, Scheme 1, GA, exact).
