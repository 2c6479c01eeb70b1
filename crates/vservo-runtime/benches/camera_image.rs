//! What publishing a frame on `camera_image` costs the vision node: loan a slice of shared memory, copy the
//! image into it, send (one subscriber attached, drained outside the timing's concern):
//! `cargo bench -p vservo-runtime`. The paper's 512 × 512 image and the largest the service carries,
//! 1280 × 1024.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use vservo_runtime::nodes::vision::publish_image;
use vservo_vision::GrayImage;

fn camera_image(c: &mut Criterion) {
    let instance = format!("bench-{}", std::process::id());
    // the bench stands in for the daemon: it claims the instance (its directory, lock and prefix)
    let claim = vservo_protocol::InstanceClaim::claim(&instance).expect("the instance");
    let node = vservo_protocol::create_node_in(claim.dir(), "bench").expect("an iceoryx2 node");
    let publisher = vservo_protocol::camera_image_publisher(&node, &instance).expect("a publisher");
    let subscriber =
        vservo_protocol::camera_image_subscriber(&node, &instance, vservo_protocol::Opening::OpenOrCreate)
            .expect("a subscriber");
    for (name, width, height) in [("publish_512x512", 512, 512), ("publish_1280x1024", 1280, 1024)] {
        let mut image = GrayImage::new(width, height);
        for (i, pixel) in image.iter_mut().enumerate() {
            *pixel = (i % 251) as u8;
        }
        let mut frame = 0;
        c.bench_function(name, |b| {
            b.iter(|| {
                frame += 1;
                publish_image(
                    &publisher,
                    black_box(&image),
                    (frame, frame),
                    vservo_protocol::Exposure::UNKNOWN,
                );
                // keep the subscriber's queue from filling, as the vision node's consumers do
                while let Ok(Some(sample)) = subscriber.receive() {
                    black_box(sample.payload().len());
                }
            })
        });
    }
}

criterion_group!(benches, camera_image);
criterion_main!(benches);
