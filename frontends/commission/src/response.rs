//! The table's frequency response through the worm (`hob commission response`): a held
//! sine on the table's target at stepped frequencies, the response of the table drive's
//! motor from the loop's state stream, the mesh's mode found from it, and the drive's
//! tuning checked against a model of its loops on the mechanism fitted to it.

pub mod model;
