//! The table drive's loops on the two-way worm mechanism (to be written).
