mod matrix;
mod vector;
