"""The input/output layer: measurement files (model-spec section 5), index pages and figures."""
