//! Built-in models with analytic first and second derivatives.
