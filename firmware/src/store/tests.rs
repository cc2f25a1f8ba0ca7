use super::*;
use embedded_storage::nor_flash::{ErrorType, NorFlashErrorKind, ReadNorFlash};

const SECTOR: usize = 1024;

/// NOR flash that loses power after a chosen number of byte operations
/// (bytes programmed or erased). After the cut every operation fails; what
/// was programmed or erased before it stays.
#[derive(Clone)]
struct CutFlash {
    data: Vec<u8>,
    budget: Option<usize>,
    ops: usize,
    write_size: usize,
}

#[derive(Debug)]
struct PowerCut;
impl embedded_storage::nor_flash::NorFlashError for PowerCut {
    fn kind(&self) -> NorFlashErrorKind {
        NorFlashErrorKind::Other
    }
}

impl CutFlash {
    fn new() -> Self {
        Self { data: vec![0xFF; 3 * SECTOR], budget: None, ops: 0, write_size: 1 }
    }
    fn spend(&mut self) -> Result<(), PowerCut> {
        if let Some(b) = self.budget {
            if self.ops >= b {
                return Err(PowerCut);
            }
        }
        self.ops += 1;
        Ok(())
    }
    fn powered_again(&self) -> Self {
        Self { data: self.data.clone(), budget: None, ops: 0, write_size: self.write_size }
    }
}

impl ErrorType for CutFlash {
    type Error = PowerCut;
}
impl ReadNorFlash for CutFlash {
    const READ_SIZE: usize = 1;
    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), PowerCut> {
        if self.budget.is_some_and(|b| self.ops >= b) {
            return Err(PowerCut);
        }
        bytes.copy_from_slice(&self.data[offset as usize..offset as usize + bytes.len()]);
        Ok(())
    }
    fn capacity(&self) -> usize {
        self.data.len()
    }
}
impl NorFlash for CutFlash {
    const WRITE_SIZE: usize = 1;
    const ERASE_SIZE: usize = SECTOR;
    fn erase(&mut self, from: u32, to: u32) -> Result<(), PowerCut> {
        // An interrupted erase leaves a prefix erased and the rest as it was.
        for i in from..to {
            self.spend()?;
            self.data[i as usize] = 0xFF;
        }
        Ok(())
    }
    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), PowerCut> {
        assert_eq!(bytes.len() % self.write_size, 0);
        for (i, b) in bytes.iter().enumerate() {
            self.spend()?;
            self.data[offset as usize + i] &= *b;
        }
        Ok(())
    }
}

fn store(f: CutFlash) -> Store<CutFlash> {
    Store::new(f, SECTOR as u32, 2 * SECTOR as u32, SECTOR as u32).unwrap()
}

#[test]
fn save_and_load_round_trip_with_growing_sequence() {
    let mut s = store(CutFlash::new());
    assert_eq!(s.load(), None);
    assert_eq!(s.save(b"first").unwrap(), 1);
    assert_eq!(s.save(b"second set").unwrap(), 2);
    assert_eq!(s.save(b"third").unwrap(), 3);
    let r = s.load().unwrap();
    assert_eq!((r.seq, r.payload.as_slice()), (3, &b"third"[..]));
    // Alternates sectors: the previous record is still there, intact.
    let f = s.release();
    let mut s = store(f);
    assert_eq!(s.read_sector(1 - r.sector).unwrap().payload.as_slice(), b"second set");
}

#[test]
fn a_power_cut_at_every_byte_of_a_save_leaves_the_old_or_the_new_set() {
    // Two saves in, then a third interrupted at every possible operation.
    let mut base = store(CutFlash::new());
    base.save(b"old coefficients v1").unwrap();
    base.save(b"old coefficients v2").unwrap();
    let flash = base.release();
    // Count the operations of a full save.
    let mut probe = store(flash.powered_again());
    probe.save(b"NEW coefficients!").unwrap();
    let total = probe.release().ops;
    assert!(total > SECTOR, "a save erases a whole sector and writes a record");
    let (mut old, mut new) = (0, 0);
    for cut in 0..=total {
        let mut f = flash.powered_again();
        f.budget = Some(cut);
        let mut s = store(f);
        let result = s.save(b"NEW coefficients!");
        assert_eq!(result.is_ok(), cut >= total, "cut at {cut}");
        let mut after = store(s.release().powered_again());
        let r = after.load().expect("a valid set survives every cut");
        match r.payload.as_slice() {
            b"old coefficients v2" => old += 1,
            b"NEW coefficients!" => new += 1,
            other => panic!("cut at {cut}: a mix or an older set: {other:?}"),
        }
    }
    // The new set appears only once the commit slot is written in full.
    assert_eq!(new, 1);
    assert_eq!(old, total);
}

#[test]
fn corrupted_records_are_ignored() {
    let mut s = store(CutFlash::new());
    s.save(b"good").unwrap();
    s.save(b"newer").unwrap();
    let mut f = s.release();
    // Flip one payload bit of the newest record (sector 1 = offset 2048).
    f.data[2 * SECTOR + HEADER] ^= 0x01;
    let mut s = store(f);
    assert_eq!(s.load().unwrap().payload.as_slice(), b"good");
}

#[test]
fn bad_layouts_and_oversized_payloads_are_refused() {
    assert_eq!(Store::new(CutFlash::new(), 10, 2048, 1024).err(), Some(StoreError::Layout));
    assert_eq!(Store::new(CutFlash::new(), 1024, 1024, 1024).err(), Some(StoreError::Layout));
    assert_eq!(Store::new(CutFlash::new(), 1024, 4096, 1024).err(), Some(StoreError::Layout));
    let mut s = store(CutFlash::new());
    assert_eq!(s.save(&[0u8; MAX_PAYLOAD + 1]), Err(StoreError::TooLarge));
}

#[test]
fn ram_flash_behaves_like_nor() {
    let mut s = Store::new(RamFlash::<4096, 1024>::new(), 0, 2048, 1024).unwrap();
    s.save(b"abc").unwrap();
    s.save(b"defg").unwrap();
    assert_eq!(s.load().unwrap().payload.as_slice(), b"defg");
}

mod arbitrary_flash {
    use super::super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn any_flash_image_loads_or_not_but_never_panics(image in proptest::collection::vec(any::<u8>(), 2048)) {
            let mut flash = RamFlash::<2048, 1024>::new();
            let _ = flash.write(0, &image);
            let mut s = Store::new(flash, 0, 1024, 1024).unwrap();
            if let Some(r) = s.load() {
                let _ = crate::device::decode_coefficients(&r.payload);
            }
            prop_assert!(s.save(b"x").is_ok());
            let back = s.load().unwrap();
            prop_assert_eq!(back.payload.as_slice(), &b"x"[..]);
        }
    }
}
