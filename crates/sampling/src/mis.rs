//! Multiple importance sampling heuristics as plain functions (PAPER.md "MIS").
//! STUB: to be implemented.
