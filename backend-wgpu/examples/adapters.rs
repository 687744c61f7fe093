//! Lists the adapters wgpu finds, in the order `AdapterChoice::Best` ranks them.
fn main() {
    let list = radiosity_backend_wgpu::adapters();
    if list.is_empty() {
        println!("no adapter");
    }
    for a in list {
        let features = a.wgpu_adapter().features();
        println!(
            "#{} {} bc={} subgroups={} timestamps={}",
            a.info.index,
            a.info,
            a.info.bc,
            features.contains(wgpu::Features::SUBGROUP),
            features.contains(wgpu::Features::TIMESTAMP_QUERY)
        );
    }
}
