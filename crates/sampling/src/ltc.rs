//! LTC line sampling: sample a linearly transformed cosine restricted to a line (PAPER.md "LTC").
//! STUB: to be implemented.
