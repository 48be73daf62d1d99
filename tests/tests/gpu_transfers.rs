//! Host ↔ device transfers through the context's reused staging memory (renderer/src/gpu/
//! staging.rs): transfers larger than one staging chunk, at offsets that do not fall on a
//! chunk's edge, round-trip every byte, and transfers from several threads at once (which then
//! use temporary staging buffers) do too.

use candela_tests::gpu;
use renderer::gpu::{Buffer, BufferUsage};

/// A byte pattern that differs at every position of a chunk (so a piece copied to the wrong
/// place shows).
fn pattern(len: usize, salt: u32) -> Vec<u8> {
    (0..len as u32)
        .map(|i| (i.wrapping_mul(2_654_435_761).wrapping_add(salt) >> 13) as u8)
        .collect()
}

#[test]
fn transfers_larger_than_a_chunk_round_trip() {
    let ctx = gpu();
    // 2.5 chunks of 32 MB, written at an offset that no chunk edge meets.
    let len = (80 << 20) + 12;
    let offset = 4096 + 20;
    let buf = Buffer::new(
        &ctx,
        "transfer test",
        (offset + len) as u64,
        BufferUsage::Storage,
    )
    .unwrap();
    let data = pattern(len, 7);
    ctx.upload(&buf, offset as u64, &data).unwrap();
    let back = ctx.download(&buf, offset as u64, len as u64).unwrap();
    assert!(back == data, "the round trip changed bytes");
    // A read that starts inside the upload and crosses a chunk edge.
    let mid = ctx
        .download(&buf, offset as u64 + (31 << 20), 2 << 20)
        .unwrap();
    assert!(mid[..] == data[31 << 20..33 << 20]);
}

#[test]
fn transfers_from_several_threads_at_once() {
    let ctx = gpu();
    std::thread::scope(|s| {
        for t in 0..4u32 {
            let ctx = ctx.clone();
            s.spawn(move || {
                let len = (3 << 20) + 4 * t as usize;
                let buf =
                    Buffer::new(&ctx, "transfer test", len as u64, BufferUsage::Storage).unwrap();
                for round in 0..3 {
                    let data = pattern(len, t * 10 + round);
                    ctx.upload(&buf, 0, &data).unwrap();
                    let back = ctx.download(&buf, 0, len as u64).unwrap();
                    assert!(back == data, "thread {t} round {round}");
                }
            });
        }
    });
}

/// A session's accumulation copied by the device into host-visible memory holds exactly what
/// the read-back returns, extra buffers (bdpt's splats) and odd half in their places, and a
/// buffer passed back is used again (its contents replaced).
#[test]
fn accumulation_to_host_equals_the_read_back() {
    use renderer::compile::compile;
    use renderer::integrators::IntegratorOptions;
    use renderer::render::{render, Budget, RenderSession};
    let scene = renderer::scene::load_file(&candela_tests::scene_path("cornell.json")).unwrap();
    let compiled = compile(&scene, 12, 8).unwrap();
    let ctx = gpu();
    let options = IntegratorOptions::from_name("bdpt").unwrap();
    let mut session = RenderSession::new(&ctx, &compiled, &options, Some(3), 3).unwrap();
    assert!(
        !session.extra_buffers().is_empty(),
        "bdpt has extra buffers"
    );
    render(&mut session, Budget::Spp(2)).unwrap();
    let read = session.accumulation().unwrap();
    let host = session.accumulation_to_host(None).unwrap();
    assert_eq!(host.len(), read.len());
    assert!(
        host.as_slice() == &read[..],
        "the copy differs from the read-back"
    );
    // More samples, into the same buffer.
    let first = read;
    render(&mut session, Budget::Spp(4)).unwrap();
    let read = session.accumulation().unwrap();
    assert!(read != first, "more samples changed nothing");
    let mapped_at = host.as_slice().as_ptr() as usize;
    let again = session.accumulation_to_host(Some(host)).unwrap();
    let at = again.as_slice().as_ptr() as usize;
    assert_eq!(at, mapped_at, "a new buffer, not the one given back");
    assert!(
        again.as_slice() == &read[..],
        "the reused buffer differs from the read-back"
    );
}
