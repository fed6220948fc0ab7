fn main() {
    println!("tetsim {}", env!("CARGO_PKG_VERSION"));
}
