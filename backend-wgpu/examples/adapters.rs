//! Lists the adapters wgpu finds, in the order `AdapterChoice::Best` ranks them.
fn main() {
    let list = radiosity_backend_wgpu::adapters();
    if list.is_empty() {
        println!("no adapter");
    }
    for a in list {
        println!("#{} {} bc={}", a.info.index, a.info, a.info.bc);
    }
}
